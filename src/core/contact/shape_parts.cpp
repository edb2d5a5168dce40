#include "fem_cloth/core/contact/shape_parts.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace fem_cloth {

namespace {

constexpr double kPi = 3.14159265358979323846;

}  // namespace

SignedDistance aroundPoint(const Eigen::Vector3d& p, const Eigen::Vector3d& c, double r) {
  SignedDistance out;
  const Eigen::Vector3d v = p - c;
  const double length = v.norm();
  out.normal = length > 0.0 ? Eigen::Vector3d(v / length) : Eigen::Vector3d::UnitZ();
  out.distance = length - r;
  out.closest = c + r * out.normal;
  return out;
}

void addQuad(ShapeMesh& m, const std::array<Eigen::Vector3d, 4>& corners, const Eigen::Vector3d& normal) {
  const int base = static_cast<int>(m.positions.size());
  for (const Eigen::Vector3d& c : corners) {
    m.positions.push_back(c);
    m.normals.push_back(normal);
  }
  m.triangles.push_back({base, base + 1, base + 2});
  m.triangles.push_back({base, base + 2, base + 3});
}

// Ring r at polar angle theta(r), shifted along z by halfLength above the equator and by
// -halfLength below it.
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

Status requiredLength(const SettingsReader& r, const std::string& key, const std::string& shape, double& out) {
  if (!r.has(key)) return Error{r.where(key) + " is required for a " + shape + " (m)"};
  return r.number(key, out);
}

}  // namespace fem_cloth
