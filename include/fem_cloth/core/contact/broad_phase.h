// Broad phase of self-contact: which pairs of primitives are close enough to need a distance.
//
// A uniform grid hashed by cell (a spatial hash, Teschner et al., "Optimized Spatial Hashing for
// Collision Detection of Deformable Objects", 2003): every box is entered in the cells it covers,
// entries are sorted by cell, and the boxes that share a cell are compared. Sorting instead of a
// hash table keeps the result, and so the whole simulation, deterministic.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <limits>
#include <utility>
#include <vector>

namespace fem_cloth {

struct Aabb {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());
  void extend(const Eigen::Vector3d& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void inflate(double margin) {
    lo.array() -= margin;
    hi.array() += margin;
  }
  bool overlaps(const Aabb& o) const {
    return (lo.array() <= o.hi.array()).all() && (o.lo.array() <= hi.array()).all();
  }
};

/// The pairs (i, j), i indexing `a` and j indexing `b`, whose boxes overlap and that `keep`
/// accepts, sorted and without repeats. With `same` (a and b the same list) only i < j.
/// cellSize (m) should be about the size of a typical box.
void overlappingPairs(const std::vector<Aabb>& a, const std::vector<Aabb>& b, bool same,
                      double cellSize, const std::function<bool(int, int)>& keep,
                      std::vector<std::pair<int, int>>& out);

}  // namespace fem_cloth
