// A symmetric sparse matrix over all DOFs whose pattern is built once per topology from the
// vertex stencils of the energy terms (plus the diagonal), so that assembly writes values into
// fixed slots and sparse factorizations can reuse their symbolic analysis from step to step.
//
// Storage: Eigen column-major compressed, full (both triangles). For vertices r and c that share
// a stencil, the d x d block (r, c) occupies, in column d*c + l, the d consecutive slots starting
// at blockColumnOffset(r, c, l).
#pragma once

#include <Eigen/SparseCore>
#include <vector>

#include "fem_cloth/core/conventions.h"

namespace fem_cloth {

class SparseHessian {
 public:
  using Matrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

  SparseHessian() = default;
  /// stencils: vertex lists (a triangle, a bending hinge...) whose vertices are all coupled.
  SparseHessian(Index numVertices, int dim, const std::vector<std::vector<Index>>& stencils);

  int dim() const { return dim_; }
  Index numVertices() const { return numVertices_; }
  const Matrix& matrix() const { return matrix_; }
  Matrix& matrix() { return matrix_; }
  double* values() { return matrix_.valuePtr(); }
  void setZero();

  /// Offset into values() of entry (d*r, d*c + l); -1 if r and c share no stencil.
  int blockColumnOffset(Index r, Index c, int l) const;
  /// Offset of the diagonal entry of DOF i.
  int diagonalOffset(Index dof) const { return diagonal_[dof]; }

  /// Offsets for all ordered vertex pairs of a stencil, laid out as
  /// [(a * size + b) * dim + l] for local vertices a, b and column l.
  void stencilOffsets(const std::vector<Index>& stencil, std::vector<int>& out) const;

  /// Adds a dense (size*d) x (size*d) element matrix, given its precomputed stencil offsets.
  template <int N>
  void addElement(const Eigen::Matrix<double, N, N>& Ke, const int* offsets) {
    const int size = N / dim_;
    double* v = values();
    for (int a = 0; a < size; ++a) {
      for (int b = 0; b < size; ++b) {
        for (int l = 0; l < dim_; ++l) {
          const int off = offsets[(a * size + b) * dim_ + l];
          for (int k = 0; k < dim_; ++k) v[off + k] += Ke(dim_ * a + k, dim_ * b + l);
        }
      }
    }
  }

 private:
  int dim_ = 3;
  Index numVertices_ = 0;
  Matrix matrix_;
  std::vector<std::vector<Index>> neighbours_;   // per column vertex: sorted row vertices
  std::vector<std::vector<int>> neighbourStart_;  // matching first-slot offsets, column l = 0
  std::vector<int> diagonal_;
};

}  // namespace fem_cloth
