// A sparse Cholesky factorisation of a scalar (vertex x vertex) SPD matrix A, applied to every
// coordinate alike: solves A X = B for the d columns of B (one per coordinate). The matrices of
// projective dynamics (integrators/projective_dynamics.h) and of the quasi-Newton solver's
// initial Hessian (solvers/quasi_newton.h) have this form, M/h^2 plus a Laplacian-like
// stiffness, the same for x, y and z: one factorisation of n x n serves the 3n unknowns.
#pragma once

#include <Eigen/SparseCholesky>
#include <vector>

#include "fem_cloth/core/conventions.h"

namespace fem_cloth {

class ScalarCholesky {
 public:
  using Matrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
  /// Row-major: one row per unknown of A, one column per coordinate.
  using Block = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  /// Factorises A (n x n, SPD) for solves with d columns; false if it is not SPD.
  bool compute(const Matrix& A, int d);
  Index size() const { return static_cast<Index>(permutation_.size()); }
  /// X = A^-1 B (n x d each, d as given to compute). Coordinates are interleaved, so that a pass
  /// over the factor serves several of them (the solve is memory bound), and split over two
  /// threads on large systems; the arithmetic is the same whatever the number of threads.
  void solve(const Block& B, Block& X);

 private:
  Eigen::SimplicialLLT<Matrix, Eigen::Lower, Eigen::AMDOrdering<int>> llt_;
  std::vector<int> outer_, inner_, permutation_;
  std::vector<double> values_;
  Block work_;     // n x (d - 1)
  VectorX tail_;   // n
};

}  // namespace fem_cloth
