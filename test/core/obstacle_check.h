// An independent check of how far the cloth's surface is from round obstacles (issue 30): every
// vertex, `samples` evenly spaced points on every mesh edge and a grid of `samples` divisions
// inside every triangle, against a sphere or a capsule
// written out here from its definition (points within r of a centre or of an axis segment),
// moving at a constant velocity. It shares nothing with the contact code under test.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <set>
#include <string>
#include <utility>

#include "fem_cloth/core/mesh.h"

namespace fem_cloth::test {

struct RoundObstacle {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();    ///< at time 0 (m)
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< m/s
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();     ///< unit; a capsule's axis
  double halfLength = 0.0;                             ///< 0: a sphere (m)
  double radius = 0.0;                                 ///< m

  /// The capsule's axis for roll 0, pitch p, yaw y: the local z turned by p about y, then by y
  /// about z: (sin p cos y, sin p sin y, cos p).
  static Eigen::Vector3d axisFromPitchYaw(double pitch, double yaw) {
    return {std::sin(pitch) * std::cos(yaw), std::sin(pitch) * std::sin(yaw), std::cos(pitch)};
  }
  Eigen::Vector3d centerAt(double t) const { return center + t * velocity; }
  /// Signed distance of p to the surface at time t (m).
  double distance(const Eigen::Vector3d& p, double t) const {
    const Eigen::Vector3d c = centerAt(t);
    const double along = std::clamp((p - c).dot(axis), -halfLength, halfLength);
    return (p - (c + along * axis)).norm() - radius;
  }
};

struct Closest {
  double distance = 1e300;  ///< m
  std::string where;        ///< "vertex 12" or "edge (3, 4) at 0.35"
};

/// The closest approach of the cloth at positions x (3 per vertex) to the obstacle at time t:
/// every vertex, `samples` points on every edge (its ends excluded, they are vertices), and the
/// points of barycentric grid with `samples` + 1 divisions inside every triangle.
inline Closest closestApproach(const Mesh& mesh, const VectorX& x, const RoundObstacle& o, double t,
                               int samples = 20) {
  Closest out;
  auto point = [&](Index v) { return Eigen::Vector3d(x.segment<3>(3 * v)); };
  for (Index v = 0; v < mesh.numVertices(); ++v) {
    const double d = o.distance(point(v), t);
    if (d < out.distance) out = {d, "vertex " + std::to_string(v)};
  }
  std::set<std::pair<Index, Index>> edges;
  for (const Triangle& tri : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      const Index a = tri[k], b = tri[(k + 1) % 3];
      edges.insert({std::min(a, b), std::max(a, b)});
    }
  }
  for (const auto& [a, b] : edges) {
    for (int j = 1; j <= samples; ++j) {
      const double s = static_cast<double>(j) / (samples + 1);
      const double d = o.distance((1.0 - s) * point(a) + s * point(b), t);
      if (d < out.distance) {
        out = {d, "edge (" + std::to_string(a) + ", " + std::to_string(b) + ") at " + std::to_string(s)};
      }
    }
  }
  const int n = samples + 1;
  for (std::size_t ti = 0; ti < mesh.triangles.size(); ++ti) {
    const Triangle& tri = mesh.triangles[ti];
    for (int i = 1; i < n; ++i) {
      for (int j = 1; i + j < n; ++j) {
        const double l0 = static_cast<double>(i) / n, l1 = static_cast<double>(j) / n;
        const double d = o.distance(l0 * point(tri[0]) + l1 * point(tri[1]) + (1.0 - l0 - l1) * point(tri[2]), t);
        if (d < out.distance) out = {d, "triangle " + std::to_string(ti) + " at (" + std::to_string(l0) + ", " + std::to_string(l1) + ")"};
      }
    }
  }
  return out;
}

}  // namespace fem_cloth::test
