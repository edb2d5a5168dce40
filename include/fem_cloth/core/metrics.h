// Measurements of a deformed cloth used in summaries, markers and reports.
#pragma once

#include <string>

#include <vector>

#include "fem_cloth/core/mesh.h"
#include "fem_cloth/core/rest_state.h"

namespace fem_cloth {

/// Edge stretch l/L - 1 over the unique edges of the mesh.
struct EdgeStretch {
  double mean = 0.0;  ///< mean of max(l/L - 1, 0): compression counts as zero
  double max = 0.0;   ///< largest l/L - 1
  double min = 0.0;   ///< smallest l/L - 1 (negative: compressed)
};

class EdgeStretchMeter {
 public:
  explicit EdgeStretchMeter(const Mesh& mesh);
  EdgeStretch measure(const VectorX& x) const;

 private:
  int dim_;
  std::vector<std::array<Index, 2>> edges_;
  std::vector<double> restLength_;
};

/// Per-triangle largest principal stretch minus one (s1 - 1 of F), for colouring by strain.
void triangleStrains(const Mesh& mesh, const RestState& rest, const VectorX& x,
                     std::vector<double>& out);

/// 64-bit FNV-1a over the bits of the positions, then the velocities, as 16 hex digits (what
/// ClothState.state_hash carries): equal hashes mean bit-identical states.
std::string stateHash(const VectorX& x, const VectorX& v);

}  // namespace fem_cloth
