#include "fem_cloth/core/contact/shapes.h"

#include <algorithm>
#include <cmath>

#include "fem_cloth/core/enum_names.h"

namespace fem_cloth {

const std::vector<std::string>& shapeTypeNames() {
  static const std::vector<std::string> names = {"plane", "sphere", "box", "capsule"};
  return names;
}

std::string shapeTypeName(ShapeType type) { return enumName(shapeTypeNames(), type); }

std::optional<ShapeType> shapeTypeFromName(const std::string& name) {
  return enumFromName<ShapeType>(shapeTypeNames(), name);
}

namespace {

// Distance to a point c (a sphere of radius r about it): the normal is the direction away from c.
SignedDistance aroundPoint(const Eigen::Vector3d& p, const Eigen::Vector3d& c, double r) {
  SignedDistance out;
  const Eigen::Vector3d v = p - c;
  const double length = v.norm();
  out.normal = length > 0.0 ? Eigen::Vector3d(v / length) : Eigen::Vector3d::UnitZ();
  out.distance = length - r;
  out.closest = c + r * out.normal;
  return out;
}

}  // namespace

SignedDistance signedDistance(const Shape& shape, const Eigen::Vector3d& p) {
  switch (shape.type) {
    case ShapeType::Plane: {
      SignedDistance out;
      out.distance = p.z();
      out.normal = Eigen::Vector3d::UnitZ();
      out.closest = Eigen::Vector3d(p.x(), p.y(), 0.0);
      return out;
    }
    case ShapeType::Sphere:
      return aroundPoint(p, Eigen::Vector3d::Zero(), shape.radius);
    case ShapeType::Capsule:
      return aroundPoint(p, Eigen::Vector3d(0.0, 0.0, std::clamp(p.z(), -shape.halfLength, shape.halfLength)),
                         shape.radius);
    case ShapeType::Box:
      break;
  }
  SignedDistance out;
  const Eigen::Vector3d& h = shape.halfExtents;
  Eigen::Vector3d sign;
  for (int k = 0; k < 3; ++k) sign[k] = p[k] >= 0.0 ? 1.0 : -1.0;
  const Eigen::Vector3d q = p.cwiseAbs() - h;
  const Eigen::Vector3d outside = q.cwiseMax(0.0);
  const double length = outside.norm();
  if (length > 0.0) {
    // Outside: the distance to the clamped point, across the faces, edges or corner the point is
    // beyond.
    out.distance = length;
    out.normal = sign.cwiseProduct(outside) / length;
    out.closest = p.cwiseMax(-h).cwiseMin(h);
  } else {
    // Inside (or on the surface): the nearest face.
    int face = 0;
    q.maxCoeff(&face);
    out.distance = q[face];
    out.normal = Eigen::Vector3d::Zero();
    out.normal[face] = sign[face];
    out.closest = p;
    out.closest[face] = sign[face] * h[face];
  }
  return out;
}

}  // namespace fem_cloth
