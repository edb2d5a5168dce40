#include "fem_cloth/core/contact/broad_phase.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace fem_cloth {

namespace {

struct Entry {
  std::uint64_t cell;
  int list;  // 0: a, 1: b
  int index;
  bool operator<(const Entry& o) const {
    if (cell != o.cell) return cell < o.cell;
    if (list != o.list) return list < o.list;
    return index < o.index;
  }
};

// A box covering more cells than this is compared with every box directly.
constexpr double kMaxCellsPerBox = 512.0;

std::uint64_t cellKey(std::int64_t i, std::int64_t j, std::int64_t k) {
  // Distinct cells may share a key; the boxes of such cells are compared needlessly, never missed.
  return static_cast<std::uint64_t>(i) * 73856093ull ^ static_cast<std::uint64_t>(j) * 19349663ull ^
         static_cast<std::uint64_t>(k) * 83492791ull;
}

}  // namespace

void overlappingPairs(const std::vector<Aabb>& a, const std::vector<Aabb>& b, bool same,
                      double cellSize, const std::function<bool(int, int)>& keep,
                      std::vector<std::pair<int, int>>& out) {
  out.clear();
  std::vector<Entry> entries;
  std::vector<int> large[2];
  const std::vector<Aabb>* lists[2] = {&a, &b};
  const int numLists = same ? 1 : 2;
  for (int list = 0; list < numLists; ++list) {
    const std::vector<Aabb>& boxes = *lists[list];
    for (int index = 0; index < static_cast<int>(boxes.size()); ++index) {
      const Aabb& box = boxes[static_cast<std::size_t>(index)];
      const Eigen::Vector3d lo = (box.lo / cellSize).array().floor();
      const Eigen::Vector3d hi = (box.hi / cellSize).array().floor();
      const Eigen::Vector3d count = hi - lo + Eigen::Vector3d::Ones();
      if (!count.allFinite() || count.prod() > kMaxCellsPerBox) {
        large[list].push_back(index);
        continue;
      }
      for (auto i = static_cast<std::int64_t>(lo.x()); i <= static_cast<std::int64_t>(hi.x()); ++i) {
        for (auto j = static_cast<std::int64_t>(lo.y()); j <= static_cast<std::int64_t>(hi.y()); ++j) {
          for (auto k = static_cast<std::int64_t>(lo.z()); k <= static_cast<std::int64_t>(hi.z()); ++k) {
            entries.push_back({cellKey(i, j, k), list, index});
          }
        }
      }
    }
  }
  std::sort(entries.begin(), entries.end());
  auto consider = [&](int i, int j) {
    if (same) {
      if (i == j) return;
      if (i > j) std::swap(i, j);
    }
    const Aabb& bi = a[static_cast<std::size_t>(i)];
    const Aabb& bj = (same ? a : b)[static_cast<std::size_t>(j)];
    if (bi.overlaps(bj) && keep(i, j)) out.emplace_back(i, j);
  };
  for (std::size_t begin = 0; begin < entries.size();) {
    std::size_t end = begin;
    while (end < entries.size() && entries[end].cell == entries[begin].cell) ++end;
    for (std::size_t p = begin; p < end; ++p) {
      for (std::size_t q = same ? p + 1 : begin; q < end; ++q) {
        if (!same && (entries[p].list != 0 || entries[q].list != 1)) continue;
        consider(entries[p].index, entries[q].index);
      }
    }
    begin = end;
  }
  // Boxes too large for the grid: against everything.
  const int sizeA = static_cast<int>(a.size());
  const int sizeB = static_cast<int>((same ? a : b).size());
  for (int i : large[0]) {
    for (int j = 0; j < sizeB; ++j) consider(i, j);
  }
  if (!same) {
    for (int j : large[1]) {
      for (int i = 0; i < sizeA; ++i) consider(i, j);
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
}

}  // namespace fem_cloth
