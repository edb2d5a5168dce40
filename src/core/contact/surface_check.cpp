#include "fem_cloth/core/contact/surface_check.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "fem_cloth/core/contact/box_features.h"

namespace fem_cloth {

namespace {

// The six functions h_i -/+ p_i(l) of the barycentric coordinates (l0, l1) of the point
// p = c + l0 (a - c) + l1 (b - c): each as value at l = 0 and gradient in l.
struct Pieces {
  std::array<double, 6> value;
  std::array<Eigen::Vector2d, 6> gradient;
};

Pieces pieces(const Eigen::Vector3d& h, const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  Pieces f;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector2d g(a[i] - c[i], b[i] - c[i]);
    f.value[static_cast<std::size_t>(2 * i)] = h[i] - c[i];
    f.gradient[static_cast<std::size_t>(2 * i)] = -g;
    f.value[static_cast<std::size_t>(2 * i + 1)] = h[i] + c[i];
    f.gradient[static_cast<std::size_t>(2 * i + 1)] = g;
  }
  return f;
}

// The depth at barycentric (l0, l1), first brought into the triangle (a candidate found a
// rounding error outside it): the minimum of the six pieces.
double depthAt(const Pieces& f, Eigen::Vector2d l) {
  l = l.cwiseMax(0.0);
  if (l.sum() > 1.0) l /= l.sum();
  double depth = std::numeric_limits<double>::infinity();
  for (std::size_t j = 0; j < 6; ++j) depth = std::min(depth, f.value[j] + f.gradient[j].dot(l));
  return depth;
}

// A candidate counts when it is inside the triangle up to rounding.
bool inTriangle(const Eigen::Vector2d& l) {
  constexpr double slack = 1e-12;
  return l.allFinite() && l[0] >= -slack && l[1] >= -slack && l.sum() <= 1.0 + slack;
}

}  // namespace

bool triangleBeyondAFace(const Eigen::Vector3d& halfExtents, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                         const Eigen::Vector3d& c) {
  return box::beyondOneFace(halfExtents, a, b, c);  // the barriers' box contact's own test
}

bool triangleSeparatedFromBox(const Eigen::Vector3d& halfExtents, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                              const Eigen::Vector3d& c) {
  if ((halfExtents.array() <= 0.0).any() || triangleBeyondAFace(halfExtents, a, b, c)) return true;
  // The box's projection on an axis is (-r, r), r = sum_i h_i |axis_i|; the triangle's is the
  // range of its vertices' projections. Disjoint on one axis: separated (a zero axis separates
  // nothing).
  auto separates = [&](const Eigen::Vector3d& axis) {
    const double r = halfExtents.dot(axis.cwiseAbs());
    const double pa = axis.dot(a), pb = axis.dot(b), pc = axis.dot(c);
    return r > 0.0 && (std::min({pa, pb, pc}) >= r || std::max({pa, pb, pc}) <= -r);
  };
  const std::array<Eigen::Vector3d, 3> sides = {b - a, c - b, a - c};
  if (separates(sides[0].cross(sides[1]))) return true;
  for (const Eigen::Vector3d& side : sides) {
    for (int i = 0; i < 3; ++i) {
      if (separates(Eigen::Vector3d::Unit(i).cross(side))) return true;
    }
  }
  return false;
}

double triangleBoxDepth(const Eigen::Vector3d& halfExtents, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                        const Eigen::Vector3d& c) {
  const Pieces f = pieces(halfExtents, a, b, c);
  // The triangle's corners (l = (1, 0), (0, 1), (0, 0): a, b, c).
  double best = std::max({depthAt(f, {1.0, 0.0}), depthAt(f, {0.0, 1.0}), depthAt(f, {0.0, 0.0})});
  // Its sides, each l = s + u d for u in [0, 1]: where pieces j and k are equal.
  const std::array<Eigen::Vector2d, 3> start = {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(0.0, 0.0),
                                                Eigen::Vector2d(1.0, 0.0)};
  const std::array<Eigen::Vector2d, 3> along = {Eigen::Vector2d(1.0, 0.0), Eigen::Vector2d(0.0, 1.0),
                                                Eigen::Vector2d(-1.0, 1.0)};
  for (std::size_t e = 0; e < 3; ++e) {
    for (std::size_t j = 0; j < 6; ++j) {
      for (std::size_t k = j + 1; k < 6; ++k) {
        const Eigen::Vector2d dg = f.gradient[j] - f.gradient[k];
        const double slope = dg.dot(along[e]);
        if (slope == 0.0) continue;  // parallel along this side: the side's ends are candidates
        const double u = -(f.value[j] - f.value[k] + dg.dot(start[e])) / slope;
        if (u >= 0.0 && u <= 1.0) best = std::max(best, depthAt(f, start[e] + u * along[e]));
      }
    }
  }
  // Inside: where three pieces are equal (two linear equations in l).
  for (std::size_t j = 0; j < 6; ++j) {
    for (std::size_t k = j + 1; k < 6; ++k) {
      for (std::size_t m = k + 1; m < 6; ++m) {
        Eigen::Matrix2d A;
        A.row(0) = (f.gradient[j] - f.gradient[k]).transpose();
        A.row(1) = (f.gradient[j] - f.gradient[m]).transpose();
        const double det = A.determinant();
        if (det == 0.0) continue;  // no single point: the maximum is at another candidate
        const Eigen::Vector2d rhs(f.value[k] - f.value[j], f.value[m] - f.value[j]);
        const Eigen::Vector2d l = A.inverse() * rhs;
        if (inTriangle(l)) best = std::max(best, depthAt(f, l));
      }
    }
  }
  return best;
}

}  // namespace fem_cloth
