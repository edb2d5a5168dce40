#include "fem_cloth/core/contact/shapes.h"

#include <algorithm>
#include <cmath>

namespace fem_cloth {

const std::vector<std::string>& shapeTypeNames() {
  static const std::vector<std::string> names = {"plane", "sphere", "box", "capsule"};
  return names;
}

std::string shapeTypeName(ShapeType type) {
  return shapeTypeNames()[static_cast<std::size_t>(type)];
}

namespace {

// Distance to a point c (a sphere of radius r about it): the normal is the direction away from c.
void aroundPoint(const Eigen::Vector3d& p, const Eigen::Vector3d& c, double r, bool wantHessian,
                 SignedDistance& out) {
  const Eigen::Vector3d v = p - c;
  const double length = v.norm();
  out.normal = length > 0.0 ? Eigen::Vector3d(v / length) : Eigen::Vector3d::UnitZ();
  out.distance = length - r;
  out.closest = c + r * out.normal;
  if (wantHessian && length > 0.0) {
    out.hessian = (Eigen::Matrix3d::Identity() - out.normal * out.normal.transpose()) / length;
  }
}

}  // namespace

SignedDistance signedDistance(const Shape& shape, const Eigen::Vector3d& p, bool wantHessian) {
  SignedDistance out;
  switch (shape.type) {
    case ShapeType::Plane:
      out.distance = p.z();
      out.normal = Eigen::Vector3d::UnitZ();
      out.closest = Eigen::Vector3d(p.x(), p.y(), 0.0);
      break;
    case ShapeType::Sphere:
      aroundPoint(p, Eigen::Vector3d::Zero(), shape.radius, wantHessian, out);
      break;
    case ShapeType::Capsule: {
      const double t = std::clamp(p.z(), -shape.halfLength, shape.halfLength);
      aroundPoint(p, Eigen::Vector3d(0.0, 0.0, t), shape.radius, wantHessian, out);
      // Beside the segment the distance does not change along the axis: the curvature is that
      // of a cylinder, (I - a a^T - n n^T) / rho.
      if (wantHessian && std::abs(p.z()) < shape.halfLength) {
        const double rho = out.distance + shape.radius;
        if (rho > 0.0) {
          out.hessian = (Eigen::Matrix3d::Identity() - out.normal * out.normal.transpose() -
                         Eigen::Vector3d::UnitZ() * Eigen::Vector3d::UnitZ().transpose()) /
                        rho;
        }
      }
      break;
    }
    case ShapeType::Box: {
      const Eigen::Vector3d& h = shape.halfExtents;
      Eigen::Vector3d sign;
      for (int k = 0; k < 3; ++k) sign[k] = p[k] >= 0.0 ? 1.0 : -1.0;
      const Eigen::Vector3d q = p.cwiseAbs() - h;
      const Eigen::Vector3d outside = q.cwiseMax(0.0);
      const double length = outside.norm();
      out.closest = p.cwiseMax(-h).cwiseMin(h);
      if (length > 0.0) {
        // Outside: the distance to the clamped point. Only the axes the point is beyond
        // ("active") take part; across them the surface curves like a sphere about the closest
        // edge or corner.
        out.distance = length;
        out.normal = sign.cwiseProduct(outside) / length;
        if (wantHessian) {
          Eigen::Matrix3d activeAxes = Eigen::Matrix3d::Zero();
          for (int k = 0; k < 3; ++k) activeAxes(k, k) = q[k] > 0.0 ? 1.0 : 0.0;
          out.hessian = (activeAxes - out.normal * out.normal.transpose()) / length;
        }
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
      break;
    }
  }
  return out;
}

}  // namespace fem_cloth
