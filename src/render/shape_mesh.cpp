#include "fem_cloth/render/shape_mesh.h"

#include <algorithm>
#include <cmath>

namespace fem_cloth {

namespace {

constexpr double kPi = 3.14159265358979323846;

void addQuad(ShapeMesh& m, const std::array<Eigen::Vector3d, 4>& corners, const Eigen::Vector3d& normal) {
  const int base = static_cast<int>(m.positions.size());
  for (const Eigen::Vector3d& c : corners) {
    m.positions.push_back(c);
    m.normals.push_back(normal);
  }
  m.triangles.push_back({base, base + 1, base + 2});
  m.triangles.push_back({base, base + 2, base + 3});
}

void addBox(ShapeMesh& m, const Eigen::Vector3d& h) {
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    for (double side : {-1.0, 1.0}) {
      std::array<Eigen::Vector3d, 4> c;
      const double du[4] = {-1, 1, 1, -1}, dv[4] = {-1, -1, 1, 1};
      for (int k = 0; k < 4; ++k) {
        c[k][axis] = side * h[axis];
        c[k][u] = du[k] * h[u];
        c[k][v] = dv[k] * h[v];
      }
      addQuad(m, c, side * Eigen::Vector3d::Unit(axis));
    }
  }
}

// Latitude-longitude rings around the z axis: ring r at polar angle theta(r), shifted along z by
// `lift(theta)` (a capsule moves its upper hemisphere up, its lower one down).
void addRoundBody(ShapeMesh& m, double radius, double halfLength, int segments) {
  const int half = std::max(2, segments / 4);  // rings per hemisphere, pole excluded
  std::vector<double> polar;
  for (int r = 0; r <= half; ++r) polar.push_back(0.5 * kPi * r / half);
  // With a cylinder between the hemispheres, the equator appears twice (top and bottom of it).
  const int equator = static_cast<int>(polar.size()) - 1;
  for (int r = 0; r <= half; ++r) polar.push_back(0.5 * kPi + 0.5 * kPi * r / half);
  const int base = static_cast<int>(m.positions.size());
  for (std::size_t r = 0; r < polar.size(); ++r) {
    const double theta = polar[r];
    const double lift = static_cast<int>(r) <= equator ? halfLength : -halfLength;
    for (int s = 0; s < segments; ++s) {
      const double phi = 2.0 * kPi * s / segments;
      const Eigen::Vector3d n(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                              std::cos(theta));
      m.positions.push_back(radius * n + Eigen::Vector3d(0.0, 0.0, lift));
      m.normals.push_back(n);
    }
  }
  const int rings = static_cast<int>(polar.size());
  for (int r = 0; r + 1 < rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      const int a = base + r * segments + s, b = base + r * segments + (s + 1) % segments;
      const int c = a + segments, d = b + segments;
      // Rings at a pole collapse to a point: their triangles have no area and draw nothing.
      m.triangles.push_back({a, c, d});
      m.triangles.push_back({a, d, b});
    }
  }
}

}  // namespace

ShapeMesh tessellate(const Shape& shape, double planeSide, int segments) {
  ShapeMesh m;
  segments = std::max(segments, 8);
  switch (shape.type) {
    case ShapeType::Plane: {
      const double h = 0.5 * planeSide;
      addQuad(m, {Eigen::Vector3d(-h, -h, 0), Eigen::Vector3d(h, -h, 0), Eigen::Vector3d(h, h, 0),
                  Eigen::Vector3d(-h, h, 0)},
              Eigen::Vector3d::UnitZ());
      break;
    }
    case ShapeType::Box:
      addBox(m, shape.halfExtents);
      break;
    case ShapeType::Sphere:
      addRoundBody(m, shape.radius, 0.0, segments);
      break;
    case ShapeType::Capsule:
      addRoundBody(m, shape.radius, shape.halfLength, segments);
      break;
  }
  return m;
}

}  // namespace fem_cloth
