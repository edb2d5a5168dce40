#include "fem_cloth/core/contact/box_features.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "fem_cloth/core/contact/primitive_distance.h"

namespace fem_cloth::box {

bool overlapsTriangle(const Eigen::Vector3d& h, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                      const Eigen::Vector3d& c) {
  // Separated along an axis when the triangle's projection lies wholly beyond the box's
  // projection radius sum_i h_i |axis_i| on one side.
  auto separates = [&](const Eigen::Vector3d& axis) {
    const double pa = axis.dot(a), pb = axis.dot(b), pc = axis.dot(c);
    const double r = h.dot(axis.cwiseAbs());
    return std::min({pa, pb, pc}) > r || std::max({pa, pb, pc}) < -r;
  };
  const std::array<Eigen::Vector3d, 3> sides{b - a, c - b, a - c};
  for (int axis = 0; axis < 3; ++axis) {
    if (separates(Eigen::Vector3d::Unit(axis))) return false;
  }
  if (separates(sides[0].cross(sides[1]))) return false;
  for (const Eigen::Vector3d& side : sides) {
    for (int axis = 0; axis < 3; ++axis) {
      const Eigen::Vector3d n = side.cross(Eigen::Vector3d::Unit(axis));
      // A side parallel to a box axis gives no axis (the face normals cover it).
      if (n.squaredNorm() > 1e-30 && separates(n)) return false;
    }
  }
  return true;
}

double triangleDistance(const Eigen::Vector3d& h, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                        const Eigen::Vector3d& c) {
  if (overlapsTriangle(h, a, b, c)) return 0.0;
  auto pointBox = [&](const Eigen::Vector3d& p) { return (p.cwiseAbs() - h).cwiseMax(0.0).squaredNorm(); };
  double smallest = std::min({pointBox(a), pointBox(b), pointBox(c)});
  for (int i = 0; i < kCorners; ++i) {
    smallest = std::min(smallest, pointTriangleDistance(corner(h, i), a, b, c).squared);
  }
  const std::array<std::array<const Eigen::Vector3d*, 2>, 3> sides{{{&a, &b}, {&b, &c}, {&c, &a}}};
  for (int j = 0; j < kEdges; ++j) {
    const std::array<int, 2> e = edge(j);
    const Eigen::Vector3d e0 = corner(h, e[0]), e1 = corner(h, e[1]);
    for (const auto& side : sides) {
      smallest = std::min(smallest, edgeEdgeDistance(e0, e1, *side[0], *side[1]).squared);
    }
  }
  return std::sqrt(smallest);
}

}  // namespace fem_cloth::box
