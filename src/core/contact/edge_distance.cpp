#include "fem_cloth/core/contact/edge_distance.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "fem_cloth/core/contact/primitive_distance.h"
#include "fem_cloth/core/contact/shape_parts.h"

namespace fem_cloth {

bool hasEdgeDistance(ShapeType type) { return type == ShapeType::Sphere || type == ShapeType::Capsule; }

std::optional<EdgeShapeDistance> edgeShapeDistance(const Shape& shape, const Eigen::Vector3d& a,
                                                   const Eigen::Vector3d& b) {
  EdgeShapeDistance out;
  const Eigen::Vector3d e = b - a;
  if (shape.type == ShapeType::Sphere || (shape.type == ShapeType::Capsule && !(shape.halfLength > 0.0))) {
    // The point of the segment nearest the centre (the origin).
    const double l2 = e.squaredNorm();
    out.along = l2 > 0.0 ? std::clamp(-a.dot(e) / l2, 0.0, 1.0) : 0.0;
    out.surface = aroundPoint(a + out.along * e, Eigen::Vector3d::Zero(), shape.radius);
    return out;
  }
  if (shape.type == ShapeType::Capsule) {
    // The closest points of the segment and the capsule's axis: r = (1 - s) a + s b - q.
    const Eigen::Vector3d c0(0.0, 0.0, -shape.halfLength), c1(0.0, 0.0, shape.halfLength);
    const PrimitiveDistance pd = edgeEdgeDistance(a, b, c0, c1);
    out.along = std::clamp(pd.weights[1], 0.0, 1.0);
    const Eigen::Vector3d onEdge = a + out.along * e;
    out.surface = aroundPoint(onEdge, onEdge - pd.r, shape.radius);
    return out;
  }
  return std::nullopt;
}

namespace {

// Whether the segment (p, q) meets the triangle (a, b, c): it crosses the triangle's plane at a
// point inside the triangle (a degenerate triangle meets nothing here: its edges answer).
bool segmentMeetsTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& q, const Eigen::Vector3d& a,
                          const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d n = (b - a).cross(c - a);
  const double dp = n.dot(p - a), dq = n.dot(q - a);
  if (dp * dq > 0.0 || dp == dq) return false;
  const Eigen::Vector3d x = p + (dp / (dp - dq)) * (q - p);
  return n.dot((b - a).cross(x - a)) >= 0.0 && n.dot((c - b).cross(x - b)) >= 0.0 &&
         n.dot((a - c).cross(x - c)) >= 0.0;
}

}  // namespace

std::optional<double> triangleShapeDistance(const Shape& shape, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                            const Eigen::Vector3d& c) {
  if (!hasEdgeDistance(shape.type)) return std::nullopt;
  const Eigen::Vector3d c0(0.0, 0.0, -shape.halfLength), c1(0.0, 0.0, shape.halfLength);
  double squared = pointTriangleDistance(c0, a, b, c).squared;
  if (shape.type == ShapeType::Capsule && shape.halfLength > 0.0) {
    if (segmentMeetsTriangle(c0, c1, a, b, c)) return -shape.radius;
    squared = std::min({squared, pointTriangleDistance(c1, a, b, c).squared, edgeEdgeDistance(c0, c1, a, b).squared,
                        edgeEdgeDistance(c0, c1, b, c).squared, edgeEdgeDistance(c0, c1, c, a).squared});
  }
  return std::sqrt(squared) - shape.radius;
}

}  // namespace fem_cloth
