// Sparse symmetric positive definite solves for Newton steps. The matrix pattern is fixed per
// topology (SparseHessian), so a direct solver analyses it once (ordering, symbolic
// factorisation) and only refactorises numerically afterwards.
#pragma once

#include <Eigen/SparseCore>
#include <memory>
#include <string>

#include "fem_cloth/core/conventions.h"
#include "fem_cloth/core/expected.h"

namespace fem_cloth {

enum class LinearSolverKind {
  Auto,      ///< direct for up to kAutoDirectLimit DOFs, CG above
  Ldlt,      ///< Eigen SimplicialLDLT with AMD ordering
  Cholmod,   ///< SuiteSparse CHOLMOD supernodal Cholesky (if built with it)
  Cg,        ///< conjugate gradients, incomplete-Cholesky preconditioned
};

constexpr Index kAutoDirectLimit = 200000;

Expected<LinearSolverKind> parseLinearSolverKind(const std::string& name);
std::string linearSolverName(LinearSolverKind kind);
bool cholmodAvailable();

class LinearSolver {
 public:
  using Matrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
  virtual ~LinearSolver() = default;
  virtual std::string name() const = 0;
  /// Factorises (direct) or prepares the preconditioner (CG) for A; the first call also
  /// analyses the pattern, later calls with the same pattern reuse that analysis.
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

/// The solver for a system of numDofs unknowns; Auto picks CHOLMOD (else LDLT) up to
/// kAutoDirectLimit DOFs and CG above.
std::unique_ptr<LinearSolver> makeLinearSolver(const LinearSolverSettings& settings, Index numDofs);

}  // namespace fem_cloth
