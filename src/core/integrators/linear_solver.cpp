#include "fem_cloth/core/integrators/linear_solver.h"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <vector>

#ifdef FEM_CLOTH_HAVE_CHOLMOD
#include <Eigen/CholmodSupport>
#endif

namespace fem_cloth {

bool cholmodAvailable() {
#ifdef FEM_CLOTH_HAVE_CHOLMOD
  return true;
#else
  return false;
#endif
}

Expected<LinearSolverKind> parseLinearSolverKind(const std::string& name) {
  if (name == "auto") return LinearSolverKind::Auto;
  if (name == "ldlt") return LinearSolverKind::Ldlt;
  if (name == "cholmod") {
    if (!cholmodAvailable()) {
      return Error{"linear solver 'cholmod' is not available: this build has no SuiteSparse "
                   "CHOLMOD (install libsuitesparse-dev and rebuild, or use 'ldlt')"};
    }
    return LinearSolverKind::Cholmod;
  }
  if (name == "cg") return LinearSolverKind::Cg;
  return Error{"unknown linear solver '" + name + "' (known: auto, ldlt, cholmod, cg)"};
}

std::string linearSolverName(LinearSolverKind kind) {
  switch (kind) {
    case LinearSolverKind::Auto: return "auto";
    case LinearSolverKind::Ldlt: return "ldlt";
    case LinearSolverKind::Cholmod: return "cholmod";
    case LinearSolverKind::Cg: return "cg";
  }
  return "?";
}

namespace {

// A direct solver: analysePattern once, factorize every call.
template <class Factorization>
class DirectSolver final : public LinearSolver {
 public:
  explicit DirectSolver(std::string name) : name_(std::move(name)) {}
  std::string name() const override { return name_; }
  bool compute(const Matrix& A) override {
    // The model's pattern is fixed; self-contact adds entries that come and go, so the pattern
    // is compared whole (cheap next to a factorisation) before the analysis is reused.
    const bool samePattern =
        analyses_ > 0 && A.nonZeros() == static_cast<Eigen::Index>(analysedInner_.size()) &&
        A.outerSize() + 1 == static_cast<Eigen::Index>(analysedOuter_.size()) &&
        std::equal(A.outerIndexPtr(), A.outerIndexPtr() + A.outerSize() + 1, analysedOuter_.begin()) &&
        std::equal(A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros(), analysedInner_.begin());
    if (!samePattern) {
      solver_.analyzePattern(A);
      analysedOuter_.assign(A.outerIndexPtr(), A.outerIndexPtr() + A.outerSize() + 1);
      analysedInner_.assign(A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros());
      ++analyses_;
    }
    solver_.factorize(A);
    return solver_.info() == Eigen::Success;
  }
  bool solve(const VectorX& b, VectorX& x) override {
    x = solver_.solve(b);
    return solver_.info() == Eigen::Success && x.allFinite();
  }

 private:
  std::string name_;
  Factorization solver_;
  std::vector<int> analysedOuter_, analysedInner_;
};

class CgSolver final : public LinearSolver {
 public:
  explicit CgSolver(const LinearSolverSettings& settings) {
    solver_.setTolerance(settings.cgTolerance);
    solver_.setMaxIterations(settings.cgMaxIterations);
  }
  std::string name() const override { return "cg"; }
  bool compute(const Matrix& A) override {
    if (analyses_ == 0) ++analyses_;
    solver_.compute(A);
    return solver_.info() == Eigen::Success;
  }
  bool solve(const VectorX& b, VectorX& x) override {
    x = solver_.solveWithGuess(b, x);
    lastIterations_ = static_cast<int>(solver_.iterations());
    return x.allFinite() && (solver_.info() == Eigen::Success || solver_.error() < 1e-4);
  }

 private:
  Eigen::ConjugateGradient<Matrix, Eigen::Lower | Eigen::Upper,
                           Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::AMDOrdering<int>>>
      solver_;
};

}  // namespace

std::unique_ptr<LinearSolver> makeLinearSolver(const LinearSolverSettings& settings,
                                               Index numDofs) {
  using Matrix = LinearSolver::Matrix;
  LinearSolverKind kind = settings.kind;
  if (kind == LinearSolverKind::Auto) {
    if (numDofs > kAutoDirectLimit) {
      kind = LinearSolverKind::Cg;
    } else {
      kind = cholmodAvailable() ? LinearSolverKind::Cholmod : LinearSolverKind::Ldlt;
    }
  }
  switch (kind) {
    case LinearSolverKind::Cg: return std::make_unique<CgSolver>(settings);
#ifdef FEM_CLOTH_HAVE_CHOLMOD
    case LinearSolverKind::Cholmod:
      return std::make_unique<DirectSolver<Eigen::CholmodSupernodalLLT<Matrix, Eigen::Lower>>>(
          "cholmod");
#endif
    default:
      return std::make_unique<
          DirectSolver<Eigen::SimplicialLDLT<Matrix, Eigen::Lower, Eigen::AMDOrdering<int>>>>(
          "ldlt");
  }
}

}  // namespace fem_cloth
