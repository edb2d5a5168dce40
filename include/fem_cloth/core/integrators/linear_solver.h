// Sparse symmetric positive definite solves for Newton steps. The matrix pattern is fixed per
// topology (SparseHessian; it grows only when self-contact couples new vertices), so a direct
// solver analyses it once (ordering, symbolic factorisation) and only refactorises numerically
// afterwards.
//
// Which factorisation `auto` picks, and why (measured: docs/performance.md, "The linear solve"),
// decided anew for each pattern by the flop count of its factor (CHOLMOD's analysis):
//   - up to kAutoSimplicialFlops, a simplicial LL^T (Eigen's, on CHOLMOD's fill-reducing
//     ordering): it calls no BLAS, so its results are the same bits on every machine running the
//     same build (the fixture bags replay bit for bit anywhere), and on such small factors it is
//     about as fast as the supernodal one;
//   - above, CHOLMOD's supernodal LL^T, whose dense updates go to the BLAS (OpenBLAS, installed
//     by scripts/install-deps, run on one thread): 1.3x faster on a 45x45 hanging cloth, 1.7x
//     at 65x65 and on the 33x33 fold (whose two layers in contact make a denser factor), but
//     OpenBLAS picks its kernels by CPU at run time, so results are bit-identical only on the
//     same machine;
//   - above kAutoDirectLimit unknowns, conjugate gradients (a direct factor no longer fits);
//   - without CHOLMOD (a build without SuiteSparse), Eigen's simplicial LDL^T.
// The direct solvers factorise the matrix permuted once by the fill-reducing ordering of its
// pattern, into storage kept from call to call: no transpose or copy of the matrix per call, and
// the simplicial path allocates nothing after the analysis (up to 16384 unknowns: beyond, Eigen
// takes its work vectors from the heap).
#pragma once

#include <Eigen/SparseCore>
#include <memory>
#include <string>

#include "fem_cloth/core/conventions.h"
#include "fem_cloth/core/expected.h"

namespace fem_cloth {

enum class LinearSolverKind {
  Auto,        ///< simplicial or supernodal by the factor's flops, CG above kAutoDirectLimit
  Simplicial,  ///< simplicial LL^T on CHOLMOD's ordering (no BLAS: bit-identical across machines)
  Cholmod,     ///< CHOLMOD supernodal LL^T (BLAS)
  Ldlt,        ///< Eigen SimplicialLDLT with AMD ordering (no SuiteSparse needed)
  Cg,          ///< conjugate gradients, incomplete-Cholesky preconditioned
};

/// Flops of the factor up to which `auto` factorises simplicially (above): the 13x13 pinch-lift
/// (1.0e6) and the 33x33 hanging cloth (7.0e6) are below, the 33x33 fold in contact (3.4e7) and
/// the 45x45 hanging cloth above.
constexpr double kAutoSimplicialFlops = 1e7;
constexpr Index kAutoDirectLimit = 200000;

Expected<LinearSolverKind> parseLinearSolverKind(const std::string& name);
std::string linearSolverName(LinearSolverKind kind);
bool cholmodAvailable();

class LinearSolver {
 public:
  using Matrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
  virtual ~LinearSolver() = default;
  virtual std::string name() const = 0;
  /// Factorises (direct) or prepares the preconditioner (CG) for A, a symmetric matrix stored
  /// whole (both triangles); the first call also analyses the pattern, later calls with the same
  /// pattern reuse that analysis.
  virtual bool compute(const Matrix& A) = 0;
  /// Solves A x = b; x holds the initial guess on entry for iterative solvers.
  virtual bool solve(const VectorX& b, VectorX& x) = 0;
  /// Number of pattern analyses so far (1 for a direct solver used on one topology).
  int analyses() const { return analyses_; }
  /// CG iterations of the last solve (0 for direct solvers).
  int lastIterations() const { return lastIterations_; }

 protected:
  int analyses_ = 0;
  int lastIterations_ = 0;
};

struct LinearSolverSettings {
  LinearSolverKind kind = LinearSolverKind::Auto;
  double cgTolerance = 1e-8;  ///< relative residual
  int cgMaxIterations = 2000;
};

/// The kind `auto` stands for with numDofs unknowns (the kind itself otherwise): CG above
/// kAutoDirectLimit, LDL^T without CHOLMOD, else Auto (decided per pattern, above).
LinearSolverKind resolveLinearSolverKind(LinearSolverKind kind, Index numDofs);

/// The solver for a system of numDofs unknowns (resolveLinearSolverKind).
std::unique_ptr<LinearSolver> makeLinearSolver(const LinearSolverSettings& settings, Index numDofs);

}  // namespace fem_cloth
