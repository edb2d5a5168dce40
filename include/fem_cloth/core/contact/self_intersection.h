// Whether a cloth passes through itself: an edge of one triangle crossing another triangle.
//
// Self-collision keeps a cloth from passing through itself, but only a cloth that starts free
// of intersections: the barrier of a pair that already crossed holds it crossed (Li et al. 2020,
// section 4: the barrier is defined on intersection-free states only). A distance check cannot
// see a crossing: an edge that pierces a large triangle is far from its corners and edges. Two
// triangles that intersect, not in one plane, meet along a segment whose ends lie on their
// edges (Moller, "A Fast Triangle-Triangle Intersection Test", 1997, section 2), so testing the
// six edges of a pair against the other triangle finds every crossing. Touching and coplanar
// overlaps put a vertex or an edge at zero distance from the other triangle, which the contact
// distance check (ContactModel::minimumSelfDistance) already refuses.
#pragma once

#include <array>
#include <optional>

#include "fem_cloth/core/mesh.h"

namespace fem_cloth {

struct SelfIntersection {
  std::array<Index, 2> edge;  ///< the vertices of the crossing edge
  Index edgeTriangle;         ///< a triangle the edge belongs to
  Index triangle;             ///< the triangle it passes through
};

/// True when the segment pq passes through the interior of triangle abc, crossing its plane
/// (both with a margin of 1e-9 relative to the sizes involved: grazing and coplanar cases are
/// not crossings).
bool segmentCrossesTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& q,
                            const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                            const Eigen::Vector3d& c);

/// A crossing of a 3D mesh at the positions x (flat, 3 per vertex), or none: pairs of triangles
/// that share no vertex, and pairs that share one (their edges opposite it), from a broad phase
/// on their bounding boxes. Triangles that share an edge meet along it and are not tested.
std::optional<SelfIntersection> findSelfIntersection(const Mesh& mesh, const VectorX& x);

}  // namespace fem_cloth
