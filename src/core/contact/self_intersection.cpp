#include "fem_cloth/core/contact/self_intersection.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "fem_cloth/core/contact/broad_phase.h"

namespace fem_cloth {

namespace {

// Signed volume (x 6) of the tetrahedron (p, q, a, b): positive when a, b turn counter-clockwise
// about the directed line pq.
double orientation(const Eigen::Vector3d& p, const Eigen::Vector3d& q, const Eigen::Vector3d& a,
                   const Eigen::Vector3d& b) {
  return (q - p).dot((a - p).cross(b - p));
}

constexpr double kRelativeMargin = 1e-9;

}  // namespace

bool segmentCrossesTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& q,
                            const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                            const Eigen::Vector3d& c) {
  // p and q strictly on opposite sides of the plane of abc.
  const Eigen::Vector3d n = (b - a).cross(c - a);
  const double dp = n.dot(p - a), dq = n.dot(q - a);
  const double planeMargin = kRelativeMargin * n.norm() * (q - p).norm();
  if (!((dp > planeMargin && dq < -planeMargin) || (dp < -planeMargin && dq > planeMargin))) {
    return false;
  }
  // The line pq passes a, b and c on the same side for every edge: through the interior.
  const double lab = orientation(p, q, a, b), lbc = orientation(p, q, b, c), lca = orientation(p, q, c, a);
  const double scale = (q - p).norm() * std::max({(a - p).norm(), (b - p).norm(), (c - p).norm()});
  const double margin = kRelativeMargin * scale * std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
  return (lab > margin && lbc > margin && lca > margin) || (lab < -margin && lbc < -margin && lca < -margin);
}

std::optional<SelfIntersection> findSelfIntersection(const Mesh& mesh, const VectorX& x) {
  if (mesh.dim != 3 || mesh.triangles.empty()) return std::nullopt;
  auto at = [&x](Index v) -> Eigen::Vector3d { return x.segment<3>(3 * v); };
  std::vector<Aabb> boxes;
  boxes.reserve(mesh.triangles.size());
  double edgeSum = 0.0;
  for (const Triangle& t : mesh.triangles) {
    Aabb box;
    for (Index v : t) box.extend(at(v));
    boxes.push_back(box);
    edgeSum += (at(t[1]) - at(t[0])).norm() + (at(t[2]) - at(t[1])).norm() + (at(t[0]) - at(t[2])).norm();
  }
  const double cellSize = std::max(edgeSum / (3.0 * static_cast<double>(mesh.triangles.size())), 1e-12);
  auto shared = [&mesh](int i, int j) {
    int count = 0;
    for (Index a : mesh.triangles[static_cast<std::size_t>(i)]) {
      for (Index b : mesh.triangles[static_cast<std::size_t>(j)]) count += a == b ? 1 : 0;
    }
    return count;
  };
  std::vector<std::pair<int, int>> pairs;
  overlappingPairs(boxes, boxes, true, cellSize, [&](int i, int j) { return shared(i, j) < 2; }, pairs);
  // Edge k of a triangle runs from corner k to corner k + 1.
  auto crosses = [&](int edgeOwner, int k, int other) -> std::optional<SelfIntersection> {
    const Triangle& e = mesh.triangles[static_cast<std::size_t>(edgeOwner)];
    const Triangle& t = mesh.triangles[static_cast<std::size_t>(other)];
    const Index p = e[k], q = e[(k + 1) % 3];
    // With a shared vertex, only the edge opposite it can cross the other triangle away from it.
    if (std::find(t.begin(), t.end(), p) != t.end() || std::find(t.begin(), t.end(), q) != t.end()) {
      return std::nullopt;
    }
    if (!segmentCrossesTriangle(at(p), at(q), at(t[0]), at(t[1]), at(t[2]))) return std::nullopt;
    return SelfIntersection{{std::min(p, q), std::max(p, q)}, edgeOwner, other};
  };
  for (const auto& [i, j] : pairs) {
    for (int k = 0; k < 3; ++k) {
      if (auto hit = crosses(i, k, j)) return hit;
      if (auto hit = crosses(j, k, i)) return hit;
    }
  }
  return std::nullopt;
}

}  // namespace fem_cloth
