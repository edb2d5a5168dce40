// Obstacle shapes as exact signed distance functions in their own frame, with the gradient (the
// outward unit normal) and the closest surface point.
//
// Shapes (local frame):
//   plane    the surface z = 0 with outward normal +z; z < 0 is inside (a table top, a floor)
//   sphere   centred at the origin, radius r
//   box      centred at the origin, half extents (hx, hy, hz) along the local axes
//   capsule  all points within r of the segment from (0, 0, -L/2) to (0, 0, L/2)
//
// Each distance is exact (not a bound), so it is 1-Lipschitz: a point that moves by s changes its
// distance by at most s. Conservative advancement (ccd.h) relies on that. Outside a convex shape
// the distance is convex, so its Hessian is positive semi-definite there; inside it is not needed
// (contact keeps every vertex outside), and an exact distance has |grad d| = 1, so the Hessian
// has the normal in its null space: contact_model.cpp projects barrier Hessians using both facts.
// Units: metres.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

namespace fem_cloth {

enum class ShapeType { Plane, Sphere, Box, Capsule };

/// The shape type names used in scenes, in the order of ShapeType: plane, sphere, box, capsule.
const std::vector<std::string>& shapeTypeNames();
std::string shapeTypeName(ShapeType type);
/// The shape type called `name`, if there is one.
std::optional<ShapeType> shapeTypeFromName(const std::string& name);

struct Shape {
  ShapeType type = ShapeType::Plane;
  double radius = 0.0;                                    ///< sphere, capsule (m)
  Eigen::Vector3d halfExtents = Eigen::Vector3d::Zero();  ///< box (m)
  double halfLength = 0.0;  ///< capsule: half the distance between its cap centres (m)
};

struct SignedDistance {
  double distance = 0.0;  ///< m, negative inside
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit gradient of the distance
  Eigen::Vector3d closest = Eigen::Vector3d::Zero();  ///< closest point on the surface
};

/// Signed distance of the local point p to the shape's surface.
SignedDistance signedDistance(const Shape& shape, const Eigen::Vector3d& p);

}  // namespace fem_cloth
