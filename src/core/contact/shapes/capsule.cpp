// The capsule: all points within r of the segment from (0, 0, -L/2) to (0, 0, L/2) of its frame.
// A scene gives its center, orientation, radius and length L; it is drawn as a cylinder of
// `segments` sides between two hemispheres.
#include <algorithm>

#include "fem_cloth/core/contact/shape_parts.h"
#include "fem_cloth/core/scene.h"

namespace fem_cloth {

namespace {

Status read(const SettingsReader& r, SceneObstacle& o) {
  FEM_CLOTH_CHECK(r.vector("center", o.center));
  FEM_CLOTH_CHECK(r.vector("orientation", o.orientation));
  FEM_CLOTH_CHECK(requiredLength(r, "radius", "capsule", o.radius));
  return requiredLength(r, "length", "capsule", o.length);
}

Status make(const SceneObstacle& s, const std::string& key, Obstacle& o) {
  FEM_CLOTH_CHECK(inRange(s.radius, kMinObstacleSize, kMaxCoordinate, key + ".radius", "m"));
  FEM_CLOTH_CHECK(inRange(s.length, 0.0, kMaxCoordinate, key + ".length", "m"));
  o.shape.radius = s.radius;
  o.shape.halfLength = 0.5 * s.length;
  return Status::success();
}

SignedDistance distance(const Shape& shape, const Eigen::Vector3d& p) {
  return aroundPoint(p, Eigen::Vector3d(0.0, 0.0, std::clamp(p.z(), -shape.halfLength, shape.halfLength)),
                     shape.radius);
}

ShapeMesh surface(const Shape& shape, double, int segments) {
  ShapeMesh m;
  addRoundBody(m, shape.radius, shape.halfLength, segments);
  return m;
}

}  // namespace

ShapeEntry capsuleEntry() {
  return {"capsule", {"center", "radius", "length", "orientation"}, read, make, distance, surface};
}

}  // namespace fem_cloth
