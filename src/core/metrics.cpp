#include "fem_cloth/core/metrics.h"

#include <algorithm>
#include <cstdio>
#include <limits>

#include "fem_cloth/core/svd.h"

namespace fem_cloth {

EdgeStretchMeter::EdgeStretchMeter(const Mesh& mesh)
    : dim_(mesh.dim), edges_(uniqueEdges(mesh.triangles)) {
  restLength_.reserve(edges_.size());
  for (const auto& e : edges_) {
    restLength_.push_back(
        (mesh.restPositions.segment(dim_ * e[0], dim_) - mesh.restPositions.segment(dim_ * e[1], dim_))
            .norm());
  }
}

EdgeStretch EdgeStretchMeter::measure(const VectorX& x) const {
  EdgeStretch s;
  if (edges_.empty()) return s;
  s.max = -std::numeric_limits<double>::infinity();
  s.min = std::numeric_limits<double>::infinity();
  double sum = 0.0;
  for (std::size_t k = 0; k < edges_.size(); ++k) {
    const auto& e = edges_[k];
    const double l = (x.segment(dim_ * e[0], dim_) - x.segment(dim_ * e[1], dim_)).norm();
    const double stretch = l / restLength_[k] - 1.0;
    sum += std::max(stretch, 0.0);
    s.max = std::max(s.max, stretch);
    s.min = std::min(s.min, stretch);
  }
  s.mean = sum / static_cast<double>(edges_.size());
  return s;
}

void triangleStrains(const Mesh& mesh, const RestState& rest, const VectorX& x,
                     std::vector<double>& out) {
  out.resize(mesh.triangles.size());
  for (Index t = 0; t < mesh.numTriangles(); ++t) {
    const double s1 = mesh.dim == 2 ? svd2(deformationGradient<2>(mesh, rest, x, t)).sigma[0]
                                    : svd3x2(deformationGradient<3>(mesh, rest, x, t)).sigma[0];
    out[t] = s1 - 1.0;
  }
}

std::string stateHash(const VectorX& x, const VectorX& v) {
  std::uint64_t h = 14695981039346656037ull;
  auto feed = [&h](const VectorX& values) {
    const unsigned char* bytes = reinterpret_cast<const unsigned char*>(values.data());
    const std::size_t n = static_cast<std::size_t>(values.size()) * sizeof(double);
    for (std::size_t i = 0; i < n; ++i) {
      h ^= bytes[i];
      h *= 1099511628211ull;
    }
  };
  feed(x);
  feed(v);
  char text[17];
  std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(h));
  return text;
}

}  // namespace fem_cloth
