#include "fem_cloth/core/svd.h"

#include <cmath>

namespace fem_cloth {

namespace {

Eigen::Matrix2d planarRotation(double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  Eigen::Matrix2d R;
  R << c, -s, s, c;
  return R;
}

// A unit vector orthogonal to v (any one; v may be zero).
Eigen::Vector3d anyOrthogonal(const Eigen::Vector3d& v) {
  const Eigen::Vector3d axis =
      std::abs(v.x()) < 0.9 * v.norm() || v.isZero() ? Eigen::Vector3d::UnitX()
                                                     : Eigen::Vector3d::UnitY();
  Eigen::Vector3d w = v.cross(axis);
  if (!(w.norm() > 0.0)) w = Eigen::Vector3d::UnitZ().cross(axis);
  return w.normalized();
}

}  // namespace

Svd<2> svd2(const Eigen::Matrix2d& F) {
  // Write F = [[a, b], [c, d]] as the sum of a scaled rotation and a scaled reflection:
  // E, H describe the rotation part and P, G the reflection part. Then
  // F = Rot(phi) diag(Q + R, Q - R) Rot(theta) with Q = |(E, H)| and R = |(P, G)|.
  // Q - R has the sign of det F = Q^2 - R^2, which gives the inversion-aware convention.
  const double E = 0.5 * (F(0, 0) + F(1, 1));
  const double P = 0.5 * (F(0, 0) - F(1, 1));
  const double G = 0.5 * (F(1, 0) + F(0, 1));
  const double H = 0.5 * (F(1, 0) - F(0, 1));
  const double Q = std::hypot(E, H);
  const double R = std::hypot(P, G);
  const double a1 = std::atan2(G, P);
  const double a2 = std::atan2(H, E);
  const double theta = 0.5 * (a2 - a1);
  const double phi = 0.5 * (a2 + a1);
  Svd<2> out;
  out.U = planarRotation(phi);
  out.sigma = Eigen::Vector2d(Q + R, Q - R);
  out.V = planarRotation(-theta);
  return out;
}

Eigen::Matrix<double, 3, 2> planeBasis(const Eigen::Matrix<double, 3, 2>& F) {
  const Eigen::Vector3d f1 = F.col(0), f2 = F.col(1);
  Eigen::Matrix<double, 3, 2> Q;
  const double n1 = f1.norm();
  Q.col(0) = n1 > 0.0 ? Eigen::Vector3d(f1 / n1) : anyOrthogonal(f2);
  const Eigen::Vector3d w = f2 - Q.col(0).dot(f2) * Q.col(0);
  const double nw = w.norm();
  Q.col(1) = nw > 0.0 ? Eigen::Vector3d(w / nw) : anyOrthogonal(Q.col(0));
  return Q;
}

Eigen::Matrix<double, 3, 2> polarRotation3x2(const Eigen::Matrix<double, 3, 2>& F) {
  const Eigen::Matrix<double, 3, 2> Q = planeBasis(F);
  const double a = Q.col(0).dot(F.col(0)), b = Q.col(0).dot(F.col(1)), d = Q.col(1).dot(F.col(1));
  const double c0 = a + d, s0 = -b;
  const double norm = std::sqrt(c0 * c0 + s0 * s0);  // entries of F: no overflow
  const double c = norm > 0.0 ? c0 / norm : 1.0, s = norm > 0.0 ? s0 / norm : 0.0;
  Eigen::Matrix<double, 3, 2> R;
  R.col(0) = c * Q.col(0) + s * Q.col(1);
  R.col(1) = -s * Q.col(0) + c * Q.col(1);
  return R;
}

Svd<3> svd3x2(const Eigen::Matrix<double, 3, 2>& F) {
  const Eigen::Matrix<double, 3, 2> Qm = planeBasis(F);
  // R = Q^T F is upper triangular: r21 = q2 . f1 = 0 by construction.
  Eigen::Matrix2d R = Qm.transpose() * F;
  R(1, 0) = 0.0;
  const Svd<2> inner = svd2(R);
  Svd<3> out;
  out.U = Qm * inner.U;
  out.sigma = inner.sigma;
  out.V = inner.V;
  // r11, r22 >= 0 up to round-off, so det R >= 0 and sigma2 >= 0; clear a round-off sign.
  if (out.sigma[1] < 0.0) {
    out.sigma[1] = -out.sigma[1];
    out.U.col(1) = -out.U.col(1);
  }
  return out;
}

}  // namespace fem_cloth
