#include "fem_cloth/core/contact/primitive_distance.h"

#include <Eigen/Dense>
#include <algorithm>

namespace fem_cloth {

namespace {

using Matrix34 = Eigen::Matrix<double, 3, 4>;
using FreeDirections = Eigen::Matrix<double, 4, Eigen::Dynamic, 0, 4, 2>;

Eigen::Vector4d unit(int k) { return Eigen::Vector4d::Unit(k); }

// Fills the result, the gradient and the Hessian from the weights at the minimum and the free
// parameter directions (see the header).
PrimitiveDistance finish(const Matrix34& X, const Eigen::Vector4d& w, const FreeDirections& U,
                         Vector12* gradient, Matrix12* hessian) {
  PrimitiveDistance out;
  out.weights = w;
  out.r = X * w;
  out.squared = out.r.squaredNorm();
  out.freeParameters = static_cast<int>(U.cols());
  if (gradient != nullptr) {
    for (int k = 0; k < 4; ++k) gradient->segment<3>(3 * k) = 2.0 * w[k] * out.r;
  }
  if (hessian != nullptr) {
    hessian->setZero();
    for (int a = 0; a < 4; ++a) {
      for (int b = 0; b < 4; ++b) {
        hessian->block<3, 3>(3 * a, 3 * b).diagonal().setConstant(2.0 * w[a] * w[b]);
      }
    }
    const int m = static_cast<int>(U.cols());
    if (m > 0) {
      const Eigen::Matrix<double, 3, Eigen::Dynamic, 0, 3, 2> E = X * U;
      Eigen::Matrix<double, 12, Eigen::Dynamic, 0, 12, 2> F(12, m);
      for (int j = 0; j < m; ++j) {
        for (int k = 0; k < 4; ++k) {
          F.block<3, 1>(3 * k, j) = 2.0 * (U(k, j) * out.r + w[k] * E.col(j));
        }
      }
      const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 2, 2> G =
          2.0 * E.transpose() * E;
      *hessian -= F * G.ldlt().solve(F.transpose());
    }
  }
  return out;
}

}  // namespace

PrimitiveDistance pointTriangleDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& t0,
                                        const Eigen::Vector3d& t1, const Eigen::Vector3d& t2,
                                        Vector12* gradient, Matrix12* hessian) {
  Matrix34 X;
  X << p, t0, t1, t2;
  // Region of the closest point (Ericson, "Real-Time Collision Detection", 2005, section 5.1.5).
  // Vertex k of the triangle is column k + 1 of X; the point is column 0.
  const Eigen::Vector3d ab = t1 - t0, ac = t2 - t0, ap = p - t0;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  FreeDirections none(4, 0), one(4, 1), two(4, 2);
  auto vertex = [&](int k) { return finish(X, unit(0) - unit(k + 1), none, gradient, hessian); };
  // Closest point t_a + g (t_b - t_a), g in (0, 1).
  auto edge = [&](int a, int b, double g) {
    one.col(0) = unit(a + 1) - unit(b + 1);
    return finish(X, unit(0) - (1.0 - g) * unit(a + 1) - g * unit(b + 1), one, gradient, hessian);
  };
  if (d1 <= 0.0 && d2 <= 0.0) return vertex(0);
  const Eigen::Vector3d bp = p - t1;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return vertex(1);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return edge(0, 1, d1 / (d1 - d3));
  const Eigen::Vector3d cp = p - t2;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return vertex(2);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return edge(0, 2, d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    return edge(1, 2, (d4 - d3) / ((d4 - d3) + (d5 - d6)));
  }
  // Inside the face: r = p - (t0 + v ab + w ac), free in v and w.
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  two.col(0) = unit(1) - unit(2);
  two.col(1) = unit(1) - unit(3);
  Eigen::Vector4d weights(1.0, -(1.0 - v - w), -v, -w);
  return finish(X, weights, two, gradient, hessian);
}

PrimitiveDistance edgeEdgeDistance(const Eigen::Vector3d& a0, const Eigen::Vector3d& a1,
                                   const Eigen::Vector3d& b0, const Eigen::Vector3d& b1,
                                   Vector12* gradient, Matrix12* hessian) {
  Matrix34 X;
  X << a0, a1, b0, b1;
  // Closest points a0 + s (a1 - a0) and b0 + t (b1 - b0) of two segments (Ericson 2005,
  // section 5.1.9), clamped to [0, 1]; nearly parallel segments are treated as parallel.
  const Eigen::Vector3d d1 = a1 - a0, d2 = b1 - b0, r0 = a0 - b0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r0);
  const double c = d1.dot(r0), b = d1.dot(d2);
  const double denom = a * e - b * b;  // = |d1 x d2|^2
  double s = 0.0, t = 0.0;
  if (denom > 1e-12 * a * e) s = std::clamp((b * f - c * e) / denom, 0.0, 1.0);
  t = (b * s + f) / e;
  if (t < 0.0) {
    t = 0.0;
    s = std::clamp(-c / a, 0.0, 1.0);
  } else if (t > 1.0) {
    t = 1.0;
    s = std::clamp((b - c) / a, 0.0, 1.0);
  }
  const Eigen::Vector4d w((1.0 - s), s, -(1.0 - t), -t);
  FreeDirections U(4, 0);
  const bool sFree = s > 0.0 && s < 1.0, tFree = t > 0.0 && t < 1.0;
  U.resize(4, (sFree ? 1 : 0) + (tFree ? 1 : 0));
  int j = 0;
  if (sFree) U.col(j++) = unit(1) - unit(0);
  if (tFree) U.col(j++) = unit(2) - unit(3);
  return finish(X, w, U, gradient, hessian);
}

Matrix12 barrierGaussNewtonHessian(const PrimitiveDistance& pd, double b1, double b2) {
  // (4 b'' s + 2 b') (w w^T) (x) (r r^T / s).
  const double curvature = std::max(4.0 * b2 * pd.squared + 2.0 * b1, 0.0) / pd.squared;
  const Eigen::Matrix3d M = curvature * pd.r * pd.r.transpose();
  Matrix12 H;
  for (int a = 0; a < 4; ++a) {
    for (int b = 0; b < 4; ++b) H.block<3, 3>(3 * a, 3 * b) = pd.weights[a] * pd.weights[b] * M;
  }
  return H;
}

double edgeCrossSquared(const Eigen::Vector3d& a0, const Eigen::Vector3d& a1,
                        const Eigen::Vector3d& b0, const Eigen::Vector3d& b1, Vector12* gradient,
                        Matrix12* hessian) {
  // c = |u|^2 |v|^2 - (u.v)^2 with u = a1 - a0, v = b1 - b0.
  const Eigen::Vector3d u = a1 - a0, v = b1 - b0;
  const double uu = u.squaredNorm(), vv = v.squaredNorm(), uv = u.dot(v);
  const double value = uu * vv - uv * uv;
  if (gradient == nullptr && hessian == nullptr) return value;
  const Eigen::Vector3d gu = 2.0 * vv * u - 2.0 * uv * v;
  const Eigen::Vector3d gv = 2.0 * uu * v - 2.0 * uv * u;
  // du/dx = (-I, I, 0, 0), dv/dx = (0, 0, -I, I).
  const double su[4] = {-1.0, 1.0, 0.0, 0.0}, sv[4] = {0.0, 0.0, -1.0, 1.0};
  if (gradient != nullptr) {
    for (int k = 0; k < 4; ++k) gradient->segment<3>(3 * k) = su[k] * gu + sv[k] * gv;
  }
  if (hessian != nullptr) {
    const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
    const Eigen::Matrix3d Huu = 2.0 * vv * I - 2.0 * v * v.transpose();
    const Eigen::Matrix3d Hvv = 2.0 * uu * I - 2.0 * u * u.transpose();
    const Eigen::Matrix3d Huv = 4.0 * u * v.transpose() - 2.0 * v * u.transpose() - 2.0 * uv * I;
    for (int a = 0; a < 4; ++a) {
      for (int b = 0; b < 4; ++b) {
        hessian->block<3, 3>(3 * a, 3 * b) = su[a] * su[b] * Huu + sv[a] * sv[b] * Hvv +
                                             su[a] * sv[b] * Huv + sv[a] * su[b] * Huv.transpose();
      }
    }
  }
  return value;
}

}  // namespace fem_cloth
