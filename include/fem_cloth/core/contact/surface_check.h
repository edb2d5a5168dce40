// What the cloth's surface, not just its vertices, does against an obstacle: exact measures on a
// whole triangle, for the explicit steppers' check after each substep (projection_contact.h) and
// for tests.
//
// triangleBoxDepth: the depth of a point p in a box centred at the origin with half extents h is
// min_i (h_i - |p_i|), how far p would have to move to leave the box (through its nearest face).
// Its largest value over a triangle is a small linear program in the barycentric coordinates
// (l0, l1) of the triangle's point: maximise the minimum of six affine functions
// h_i - p_i(l), h_i + p_i(l) over the triangle l0, l1 >= 0, l0 + l1 <= 1. A concave
// piecewise-linear function reaches its maximum over a polygon at a vertex of its pieces'
// arrangement clipped to the polygon: a corner of the triangle, a point of a triangle side where
// two of the six functions are equal, or an interior point where three are. There are
// 3 + 3 x 15 + 20 = 68 such candidates; the largest of the function's values at those inside the
// triangle is the exact maximum (no sampling). Units: metres.
#pragma once

#include <Eigen/Core>

namespace fem_cloth {

/// The largest depth (m) of any point of the triangle (a, b, c), given in the box's frame, in the
/// box centred at the origin with half extents `halfExtents` (m, each > 0): max over the points p
/// of the triangle of min_i (halfExtents_i - |p_i|), exact. Positive: that deep inside (the
/// distance the deepest point would have to move to leave the box). Zero: touching the surface.
/// Negative: no point of the triangle is inside the box; the value is then minus the smallest,
/// over the triangle's points, of max_i (|p_i| - halfExtents_i), the distance from the box in
/// the maximum (L-infinity) norm, not the Euclidean distance (which is at least as large).
double triangleBoxDepth(const Eigen::Vector3d& halfExtents, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                        const Eigen::Vector3d& c);

/// True when the three points lie beyond the plane of one face of the box (all of them
/// p_i > h_i, or all p_i < -h_i, for one axis i): then no point of their triangle is inside the
/// box (the half-space beyond a face holds no point of it) and triangleBoxDepth is negative. A
/// cheap test before the exact one (a cloth lying on a table's top).
bool triangleBeyondAFace(const Eigen::Vector3d& halfExtents, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                         const Eigen::Vector3d& c);

/// True when a plane separates the triangle from the open box centred at the origin with half
/// extents `halfExtents` (m; any <= 0: an empty box, true): the separating axis test on the
/// box's three face normals (triangleBeyondAFace), the triangle's normal and the nine cross
/// products of the box's axes with the triangle's sides. Then no point of the triangle is inside
/// and triangleBoxDepth is <= 0; with the half extents shrunk by d, triangleBoxDepth with the
/// real ones is <= d, so that a triangle that cannot be deeper than the deepest found so far is
/// skipped exactly. False (no such plane): the triangle reaches into the box (or touches it).
bool triangleSeparatedFromBox(const Eigen::Vector3d& halfExtents, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                              const Eigen::Vector3d& c);

}  // namespace fem_cloth
