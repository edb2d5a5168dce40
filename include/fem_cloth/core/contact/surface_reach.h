// How deep the cloth's surface can reach into an obstacle between vertices the explicit steppers
// keep out, bounded before a run (issue 30, finding 2).
//
// The projection of symplectic Euler and XPBD (projection_contact.h) keeps each vertex at least
// dHat outside every obstacle; the points between the vertices are not held. How far they can
// reach in follows from the triangle's size alone. For a point x of a triangle with vertices p_i
// and barycentric weights lambda_i, min_i |x - p_i|^2 <= sum_i lambda_i |x - p_i|^2 <= rho^2,
// rho the triangle's lattice radius (surface_samples.h: its circumradius when acute, else half
// its longest side). Then:
//   - a point D deep in a convex shape has a ball of radius D around it inside the shape, so
//     every vertex is at least D + dHat from it: D <= rho - dHat (a box's sharp edge);
//   - a sphere's or a capsule's squared distance to its core f (the centre, the axis) has a
//     Hessian of at most 2 I, so f(x) >= min_i f(p_i) - rho^2 >= (r + dHat)^2 - rho^2:
//     D <= r - sqrt((r + dHat)^2 - rho^2);
//   - a plane: the triangle stays on the side of its vertices, D = 0.
// No point is deeper than the shape's half thickness (a box's smallest half extent, a radius). A
// triangle whose rho is so large that the bound reaches it can let the obstacle pass between its
// vertices (a 2 cm rod through a cloth of 8 cm cells): only a tolerance of that half thickness
// (any depth) accepts it. rho is taken at contact.surface_stretch times the rest size (the
// stretch the barriers' lattice allows for too).
#pragma once

#include <optional>
#include <string>

#include "fem_cloth/core/contact/shapes.h"

namespace fem_cloth {

struct Scene;

/// The deepest (m) a triangle with lattice radius rho (m) whose vertices are dHat (m) outside
/// `shape` can reach into it; the shape's half thickness, and `through` set, if the shape can
/// pass between the vertices.
double surfaceReachBound(const Shape& shape, double rho, double dHat, bool* through = nullptr);

struct SurfaceReach {
  std::string obstacle;  ///< its name
  Shape shape;
  double rho = 0.0;      ///< m, the mesh's largest lattice radius at contact.surface_stretch
  double depth = 0.0;    ///< m, surfaceReachBound
  bool through = false;  ///< the obstacle can pass between the vertices
};

/// For the explicit steppers: the first obstacle of the scene that the cloth's triangles could
/// reach deeper into than contact.surface_tolerance, or that could pass between their vertices;
/// nothing if every bound is within the tolerance (or the mesh or an obstacle entry is invalid,
/// which is refused elsewhere, naming its key).
std::optional<SurfaceReach> findSurfaceReach(const Scene& scene);

/// "box 'table': it keeps the vertices contact.distance (2.00 mm) out, and between them a
/// triangle (points up to 42.43 mm from its nearest vertex at contact.surface_stretch 1.5) may
/// reach up to 40.43 mm into it, more than contact.surface_tolerance (2.00 mm)", or "... is wide
/// enough for the obstacle to pass between its vertices".
std::string surfaceReachText(const SurfaceReach& reach, const Scene& scene);
/// How to accept or avoid it: "set contact.surface_tolerance: 0.0405 to accept that depth, which
/// is then measured after every substep, or refine the mesh", or for a pass-through "refine the
/// mesh: its triangles' points must stay within 22.00 mm of a vertex at that stretch, now 88.39
/// mm (contact.surface_tolerance: 0.02, the obstacle's half thickness, accepts any depth)".
std::string surfaceReachHint(const SurfaceReach& reach, const Scene& scene);

}  // namespace fem_cloth
