#include "fem_cloth/render/shading.h"

#include <algorithm>
#include <cmath>

#include "fem_cloth/core/metrics.h"

namespace fem_cloth {

void vertexNormals(const Mesh& mesh, const VectorX& x, std::vector<Eigen::Vector3d>& normals) {
  normals.assign(static_cast<std::size_t>(mesh.numVertices()), Eigen::Vector3d::Zero());
  if (mesh.dim == 3) {
    for (const Triangle& t : mesh.triangles) {
      const Eigen::Vector3d a = vertex3(mesh, x, t[0]);
      // Twice the area times the unit normal: summing it weights each triangle by its area.
      const Eigen::Vector3d n = (vertex3(mesh, x, t[1]) - a).cross(vertex3(mesh, x, t[2]) - a);
      for (Index v : t) normals[v] += n;
    }
  }
  for (Eigen::Vector3d& n : normals) {
    const double length = n.norm();
    n = length > 0.0 && std::isfinite(length) ? Eigen::Vector3d(n / length) : Eigen::Vector3d::UnitZ();
  }
}

void vertexAverages(const Mesh& mesh, const VectorX& x, const std::vector<double>& perTriangle,
                    std::vector<double>& perVertex) {
  perVertex.assign(static_cast<std::size_t>(mesh.numVertices()), 0.0);
  std::vector<double> weight(perVertex.size(), 0.0);
  for (Index t = 0; t < mesh.numTriangles(); ++t) {
    const double area = triangleArea(mesh, x, t);
    for (Index v : mesh.triangles[t]) {
      perVertex[v] += area * perTriangle[t];
      weight[v] += area;
    }
  }
  for (std::size_t v = 0; v < perVertex.size(); ++v) {
    perVertex[v] = weight[v] > 0.0 ? perVertex[v] / weight[v] : 0.0;
  }
}

Colour shade(const Colour& base, const Eigen::Vector3d& normal, const Light& light) {
  const double lit = std::abs(normal.dot(light.direction.normalized()));
  const float intensity = light.ambient + light.diffuse * static_cast<float>(lit);
  return (intensity * base).cwiseMin(1.0f);
}

Colour strainColour(double strain, double maxStrain) {
  const float u = static_cast<float>(std::clamp(strain / maxStrain, 0.0, 1.0));
  if (u < 0.5f) {
    const float w = 2.0f * u;
    return {0.15f + 0.85f * w, 0.35f + 0.65f * w, 1.0f};
  }
  const float w = 2.0f * (u - 0.5f);
  return {1.0f, 1.0f - 0.8f * w, 1.0f - 0.85f * w};
}

void clothVertexColours(const Mesh& mesh, const RestState& rest, const VectorX& x,
                        const std::vector<Eigen::Vector3d>& normals, const ClothLook& look,
                        std::vector<Colour>& colours) {
  const std::size_t n = static_cast<std::size_t>(mesh.numVertices());
  colours.resize(n);
  std::vector<double> strain;
  if (look.byStrain) {
    std::vector<double> perTriangle;
    triangleStrains(mesh, rest, x, perTriangle);
    vertexAverages(mesh, x, perTriangle, strain);
  }
  for (std::size_t v = 0; v < n; ++v) {
    const Colour base = look.byStrain ? strainColour(strain[v], look.strainColourMax) : look.colour;
    colours[v] = shade(base, normals[v], look.light);
  }
}

}  // namespace fem_cloth
