// The distance from a cloth edge (a segment) to an obstacle shape: the smallest signed distance
// of any point of the segment, for the shapes on which that point can lie inside the segment.
//
// Vertex contact alone lets an edge cut into a round obstacle between its two vertices (a 2 cm
// rod between vertices 8 cm apart passes through the cloth; issue 30). The closest point of a
// segment to
//   a sphere   is the point of the segment nearest the centre;
//   a capsule  is the point of the segment nearest the capsule's axis segment (edgeEdgeDistance);
//   a plane    is always one of its ends (the distance is linear along it): vertex contact covers
//              it, so no edge distance is given;
//   a box      is not covered here: its corners and edges take barriers against the cloth's
//              triangles and edges (box_features.h, box_contact.cpp).
// Along the segment p(s) = a + s (b - a) the signed distance of a convex shape is convex, and at
// its minimum s* the envelope theorem gives d(d)/da = (1 - s*) n, d(d)/db = s* n with n the
// shape's outward normal at the closest point. Units: metres. Shape frame in, shape frame out.
#pragma once

#include <Eigen/Core>
#include <optional>

#include "fem_cloth/core/contact/shapes.h"

namespace fem_cloth {

struct EdgeShapeDistance {
  SignedDistance surface;  ///< distance, outward normal and closest surface point
  double along = 0.0;      ///< s* in [0, 1]: the segment's closest point is a + s* (b - a)
};

/// True for the shapes edgeShapeDistance() answers for (sphere, capsule).
bool hasEdgeDistance(ShapeType type);

/// The signed distance of the segment (a, b), in the shape's frame, to the shape; nothing for
/// the shapes hasEdgeDistance() is false for.
std::optional<EdgeShapeDistance> edgeShapeDistance(const Shape& shape, const Eigen::Vector3d& a,
                                                   const Eigen::Vector3d& b);

/// The smallest signed distance (m) of any point of the triangle (a, b, c), in the shape's frame,
/// to the shape, for the shapes hasEdgeDistance() is true for (exact: the distance of the
/// triangle to the shape's core, a point or a segment, minus the radius); nothing for others.
/// What the contact model checks its surface samples' promise against (surface_samples.h).
std::optional<double> triangleShapeDistance(const Shape& shape, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                            const Eigen::Vector3d& c);

}  // namespace fem_cloth
