// Obstacle shapes as exact signed distance functions in their own frame, with the gradient (the
// outward unit normal) and the closest surface point; and the shape table: one entry per shape
// with everything the core, the scene reader and the drawing code know of it.
//
// Shapes (local frame), each defined in src/core/contact/shapes/<name>.cpp:
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
//
// A new shape: its entry file (src/core/contact/shapes/<name>.cpp, defining <name>Entry()), its
// line in ShapeType, its declaration and place in shapeRegistry() below (and its parameters in
// Shape), and the file in CMakeLists.txt. The scene reader, makeObstacle, contact, fem_cloth_render
// and the RViz markers (a triangle list made from its surface) then take it.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "fem_cloth/core/expected.h"

namespace fem_cloth {

struct Obstacle;
struct SceneObstacle;
class SettingsReader;

/// Every shape, in the order of shapeRegistry().
enum class ShapeType { Plane, Sphere, Box, Capsule };

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

/// A shape's surface as triangles in the shape's own frame, with unit outward vertex normals, for
/// drawing.
struct ShapeMesh {
  std::vector<Eigen::Vector3d> positions;  ///< m, in the shape's frame
  std::vector<Eigen::Vector3d> normals;    ///< unit, outward
  std::vector<std::array<int, 3>> triangles;
};

/// One obstacle shape.
struct ShapeEntry {
  std::string name;  ///< obstacles[i].type
  /// Its keys in an obstacle entry, besides name, type, friction, frame, velocity and trajectory
  /// (which every obstacle has), in the order messages list them.
  std::vector<std::string> keys;
  /// Reads those keys into the scene entry (SceneObstacle's fields), refusing a missing one that
  /// it requires.
  Status (*read)(const SettingsReader& reader, SceneObstacle& entry) = nullptr;
  /// Range checks on those keys, naming them (`key`: the entry's path, "obstacles[2]"), and the
  /// shape's parameters in `out.shape`. `out.geometry` comes placed by center and orientation; a
  /// shape placed otherwise (the plane: point and normal) sets it.
  Status (*make)(const SceneObstacle& entry, const std::string& key, Obstacle& out) = nullptr;
  /// Signed distance of the local point p to the surface.
  SignedDistance (*distance)(const Shape& shape, const Eigen::Vector3d& p) = nullptr;
  /// The surface as triangles: `planeSide` is the side of the square that stands for an unbounded
  /// surface, `segments` (at least 8) how many sides a round one has around.
  ShapeMesh (*triangulate)(const Shape& shape, double planeSide, int segments) = nullptr;
};

ShapeEntry planeEntry();
ShapeEntry sphereEntry();
ShapeEntry boxEntry();
ShapeEntry capsuleEntry();

/// Every shape, in ShapeType's order: the one list of them.
inline const std::vector<ShapeEntry>& shapeRegistry() {
  static const std::vector<ShapeEntry> entries = {planeEntry(), sphereEntry(), boxEntry(), capsuleEntry()};
  return entries;
}

inline const ShapeEntry& shapeEntry(ShapeType type) { return shapeRegistry()[static_cast<std::size_t>(type)]; }

/// The shape type names used in scenes, in the order of ShapeType: plane, sphere, box, capsule.
const std::vector<std::string>& shapeTypeNames();
std::string shapeTypeName(ShapeType type);
/// The shape type called `name`, if there is one.
std::optional<ShapeType> shapeTypeFromName(const std::string& name);

/// Signed distance of the local point p to the shape's surface.
inline SignedDistance signedDistance(const Shape& shape, const Eigen::Vector3d& p) {
  return shapeEntry(shape.type).distance(shape, p);
}

}  // namespace fem_cloth
