// The sphere: centred at the origin of its frame, radius r. A scene gives its center and radius;
// it is drawn as latitude-longitude bands.
#include "fem_cloth/core/contact/shape_parts.h"
#include "fem_cloth/core/scene.h"

namespace fem_cloth {

namespace {

Status read(const SettingsReader& r, SceneObstacle& o) {
  FEM_CLOTH_CHECK(r.vector("center", o.center));
  return requiredLength(r, "radius", "sphere", o.radius);
}

Status make(const SceneObstacle& s, const std::string& key, Obstacle& o) {
  FEM_CLOTH_CHECK(inRange(s.radius, kMinObstacleSize, kMaxCoordinate, key + ".radius", "m"));
  o.shape.radius = s.radius;
  return Status::success();
}

SignedDistance distance(const Shape& shape, const Eigen::Vector3d& p) {
  return aroundPoint(p, Eigen::Vector3d::Zero(), shape.radius);
}

ShapeMesh surface(const Shape& shape, double, int segments) {
  ShapeMesh m;
  addRoundBody(m, shape.radius, 0.0, segments);
  return m;
}

}  // namespace

ShapeEntry sphereEntry() { return {"sphere", {"center", "radius"}, read, make, distance, surface}; }

}  // namespace fem_cloth
