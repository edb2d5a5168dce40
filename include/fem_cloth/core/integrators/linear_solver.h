// Sparse symmetric positive definite solves for Newton steps. The matrix pattern is fixed per
// topology (SparseHessian; it grows only when self-contact couples new vertices), so a direct
// solver analyses it once (ordering, symbolic factorisation) and only refactorises numerically
// afterwards.
//
// Which factorisation `auto` picks, and why (measured: docs/performance.md, "The linear solve"):
//   - up to kAutoSimplicialLimit unknowns, a simplicial LL^T (Eigen's, on CHOLMOD's fill-reducing
//     ordering): it calls no BLAS, so its results are the same bits on every machine running the
//     same build (the fixture bags replay bit for bit anywhere), and on small systems it is as
//     fast as the supernodal one or faster (whole 0.05 s backward Euler runs of the hanging
//     cloth, 2026-12: 13 against 19 ms at 17x17, 94 against 91 ms at 33x33);
//   - above, CHOLMOD's supernodal LL^T, whose dense updates go to the BLAS (OpenBLAS, installed
//     by scripts/install-deps, run on one thread): 1.3x faster at 45x45, 1.7x at 65x65, but
//     OpenBLAS picks its kernels by CPU at run time, so results are bit-identical only on the
//     same machine;
//   - above kAutoDirectLimit, conjugate gradients (a direct factor no longer fits comfortably);
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
  Auto,        ///< simplicial, then supernodal, then CG, by size (above)
  Simplicial,  ///< simplicial LL^T on CHOLMOD's ordering (no BLAS: bit-identical across machines)
  Cholmod,     ///< CHOLMOD supernodal LL^T (BLAS)
  Ldlt,        ///< Eigen SimplicialLDLT with AMD ordering (no SuiteSparse needed)
  Cg,          ///< conjugate gradients, incomplete-Cholesky preconditioned
};

/// Unknowns up to which `auto` factorises simplicially (measured crossover: above).
constexpr Index kAutoSimplicialLimit = 4000;
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

/// The kind `auto` stands for with numDofs unknowns (the kind itself otherwise).
LinearSolverKind resolveLinearSolverKind(LinearSolverKind kind, Index numDofs);

/// The solver for a system of numDofs unknowns (resolveLinearSolverKind).
std::unique_ptr<LinearSolver> makeLinearSolver(const LinearSolverSettings& settings, Index numDofs);

}  // namespace fem_cloth
