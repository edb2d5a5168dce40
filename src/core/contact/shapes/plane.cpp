// The plane: the surface z = 0 of its frame, outward normal +z, z < 0 inside (a table top, a
// floor). A scene gives a point on it and its normal (any length); it is drawn as a square.
#include <Eigen/Geometry>

#include "fem_cloth/core/contact/shape_parts.h"
#include "fem_cloth/core/scene.h"

namespace fem_cloth {

namespace {

Status read(const SettingsReader& r, SceneObstacle& o) {
  FEM_CLOTH_CHECK(r.vector("point", o.point));
  return r.vector("normal", o.normal);
}

Status make(const SceneObstacle& s, const std::string& key, Obstacle& o) {
  FEM_CLOTH_CHECK(boundedPosition(s.point, key + ".point"));
  FEM_CLOTH_CHECK(finiteVector(s.normal, key + ".normal"));
  // Any length, but one whose direction is defined: not zero, not so small or large that
  // normalising it under- or overflows.
  if (!(s.normal.norm() > 1e-100 && s.normal.norm() < 1e100)) {
    return Error{key + ".normal must not be zero, got length " + numberText(s.normal.norm())};
  }
  // The shape frame's z axis along the normal.
  o.geometry.linear() =
      Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), s.normal.normalized()).toRotationMatrix();
  o.geometry.translation() = s.point;
  return Status::success();
}

SignedDistance distance(const Shape&, const Eigen::Vector3d& p) {
  SignedDistance out;
  out.distance = p.z();
  out.normal = Eigen::Vector3d::UnitZ();
  out.closest = Eigen::Vector3d(p.x(), p.y(), 0.0);
  return out;
}

ShapeMesh surface(const Shape&, double planeSide, int) {
  ShapeMesh m;
  const double h = 0.5 * planeSide;
  addQuad(m, {Eigen::Vector3d(-h, -h, 0), Eigen::Vector3d(h, -h, 0), Eigen::Vector3d(h, h, 0),
              Eigen::Vector3d(-h, h, 0)},
          Eigen::Vector3d::UnitZ());
  return m;
}

}  // namespace

ShapeEntry planeEntry() { return {"plane", {"point", "normal"}, read, make, distance, surface}; }

}  // namespace fem_cloth
