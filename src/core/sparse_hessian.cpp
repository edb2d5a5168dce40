#include "fem_cloth/core/sparse_hessian.h"

#include <algorithm>

namespace fem_cloth {

SparseHessian::SparseHessian(Index numVertices, int dim,
                             const std::vector<std::vector<Index>>& stencils)
    : dim_(dim), numVertices_(numVertices) {
  neighbours_.assign(numVertices, {});
  for (Index i = 0; i < numVertices; ++i) neighbours_[i].push_back(i);
  for (const auto& stencil : stencils) {
    for (Index a : stencil) {
      for (Index b : stencil) neighbours_[a].push_back(b);
    }
  }
  std::size_t nnz = 0;
  for (auto& list : neighbours_) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    nnz += list.size() * dim * dim;
  }
  const Index n = numVertices * dim;
  matrix_.resize(n, n);
  matrix_.resizeNonZeros(static_cast<Eigen::Index>(nnz));
  int* outer = matrix_.outerIndexPtr();
  int* inner = matrix_.innerIndexPtr();
  neighbourStart_.assign(numVertices, {});
  diagonal_.assign(n, -1);
  int pos = 0;
  for (Index c = 0; c < numVertices; ++c) {
    const auto& rows = neighbours_[c];
    neighbourStart_[c].resize(rows.size());
    for (int l = 0; l < dim; ++l) {
      outer[dim * c + l] = pos;
      for (std::size_t j = 0; j < rows.size(); ++j) {
        if (l == 0) neighbourStart_[c][j] = pos;
        for (int k = 0; k < dim; ++k) {
          inner[pos] = dim * rows[j] + k;
          if (rows[j] == c && k == l) diagonal_[dim * c + l] = pos;
          ++pos;
        }
      }
    }
  }
  outer[n] = pos;
  setZero();
}

void SparseHessian::setZero() {
  std::fill(matrix_.valuePtr(), matrix_.valuePtr() + matrix_.nonZeros(), 0.0);
}

int SparseHessian::blockColumnOffset(Index r, Index c, int l) const {
  const auto& rows = neighbours_[c];
  const auto it = std::lower_bound(rows.begin(), rows.end(), r);
  if (it == rows.end() || *it != r) return -1;
  const int first = neighbourStart_[c][static_cast<std::size_t>(it - rows.begin())];
  // Column l of vertex c starts rows.size()*dim slots after column l-1.
  return first + l * static_cast<int>(rows.size()) * dim_;
}

void SparseHessian::stencilOffsets(const std::vector<Index>& stencil, std::vector<int>& out) const {
  const int size = static_cast<int>(stencil.size());
  out.resize(static_cast<std::size_t>(size * size * dim_));
  for (int a = 0; a < size; ++a) {
    for (int b = 0; b < size; ++b) {
      for (int l = 0; l < dim_; ++l) {
        out[(a * size + b) * dim_ + l] = blockColumnOffset(stencil[a], stencil[b], l);
      }
    }
  }
}

}  // namespace fem_cloth
