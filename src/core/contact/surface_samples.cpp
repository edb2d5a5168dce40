#include "fem_cloth/core/contact/surface_samples.h"

#include <Eigen/Geometry>
#include <algorithm>

#include "fem_cloth/core/mesh.h"

namespace fem_cloth {

double latticeRadius(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  // sum_i lambda_i |p_i - x|^2 is concave in x (sum_i lambda_i |p_i|^2 - |x|^2 with lambda
  // linear in x); its maximum is at the circumcentre when that lies inside (an acute triangle),
  // else on the longest side, at its midpoint: half that side.
  const double ab = (b - a).squaredNorm(), bc = (c - b).squaredNorm(), ca = (a - c).squaredNorm();
  const double longest = std::max({ab, bc, ca});
  if (2.0 * longest >= ab + bc + ca) return 0.5 * std::sqrt(longest);  // right or obtuse
  const double area2 = (b - a).cross(c - a).squaredNorm();             // (2 area)^2
  return std::sqrt(ab * bc * ca / (4.0 * area2));                      // abc / (4 area)
}

double restLatticeRadius(const Mesh& mesh, const std::array<Index, 3>& t) {
  return latticeRadius(vertex3(mesh, mesh.restPositions, t[0]), vertex3(mesh, mesh.restPositions, t[1]),
                       vertex3(mesh, mesh.restPositions, t[2]));
}

double largestRestLatticeRadius(const Mesh& mesh) {
  double rho = 0.0;
  for (const Triangle& t : mesh.triangles) rho = std::max(rho, restLatticeRadius(mesh, t));
  return rho;
}

std::vector<SurfaceSample> surfaceSamples(const Mesh& mesh, const VectorX& vertexMass, int divisions) {
  std::vector<SurfaceSample> out;
  const int k = divisions;
  if (k <= 1) return out;
  const double scale = 1.0 / (static_cast<double>(k) * k);
  auto add = [&](std::array<Index, 3> v, Eigen::Vector3d w, int count) {
    SurfaceSample s;
    s.vertices = v;
    s.weights = w;
    s.count = count;
    for (int i = 0; i < count; ++i) s.mass += w[i] * vertexMass[v[static_cast<std::size_t>(i)]];
    s.mass *= scale * k * k;
    out.push_back(s);
  };
  for (const auto& e : uniqueEdges(mesh.triangles)) {
    for (int j = 1; j < k; ++j) {
      const double s = static_cast<double>(j) / k;
      add({e[0], e[1], e[1]}, Eigen::Vector3d(1.0 - s, s, 0.0), 2);
    }
  }
  for (const Triangle& t : mesh.triangles) {
    for (int i = 1; i < k; ++i) {
      for (int j = 1; i + j < k; ++j) {
        add(t, Eigen::Vector3d(i, j, k - i - j) / static_cast<double>(k), 3);
      }
    }
  }
  return out;
}

}  // namespace fem_cloth
