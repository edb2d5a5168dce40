// Newton's method on an incremental potential (potential/incremental_potential.h), for the
// implicit steppers and any other minimisation of Phi.
//
// Each iteration solves H dx = -dPhi/dx with H the Hessian of Phi with per-element PSD-projected
// blocks (so every direction descends; Teran, Sifakis, Irving & Fedkiw 2005), then searches along
// dx (solvers/line_search.h): the step is first cut to the fraction the step-bounding terms find
// safe (continuous collision detection), then backtracked until Phi decreases enough (Armijo).
// States outside a term's domain have Phi = +inf and are always rejected. Pinned DOFs are constraints, eliminated:
// their rows and columns become the identity (scaled by their mass) with zero right-hand side,
// which keeps the matrix pattern, and so the symbolic factorisation, fixed while pins come and go.
//
// Convergence needs both (a) the Newton-decrement criterion of Li et al., "Incremental Potential
// Contact", 2020: Newton converges quadratically, so the length of the last full step bounds the
// remaining error; and (b) balanced forces, which the caller measures (acceptance test (a)).
// A failed solve leaves the iterate where it stopped: the caller rolls back.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "fem_cloth/core/integrators/integrator.h"
#include "fem_cloth/core/integrators/linear_solver.h"
#include "fem_cloth/core/potential/incremental_potential.h"
#include "fem_cloth/core/solvers/line_search.h"

namespace fem_cloth {

struct NewtonSettings {
  int maxIterations = 50;
  /// Converged when the last full Newton step, as a velocity |dx|_inf / h, is below
  /// tolerance x the rest bounding-box diagonal (a velocity error in cloth sizes per second)
  /// and the forces are balanced (acceptance test (a), StepInput::residualScale).
  /// The default, 1e-3, allows 1.4e-5 m per 0.01 s step on a 1 m cloth: far below backward
  /// Euler's own truncation error (about g h^2 / 2 = 5e-4 m).
  double tolerance = 1e-3;
  int maxBacktracks = 40;
  double armijo = 1e-4;  ///< sufficient-decrease constant of the line search
  LinearSolverSettings linear;
};

using NewtonIterate = PotentialIterate;

/// What the solver minimises, and when it may stop.
struct NewtonProblem {
  IncrementalPotential* potential = nullptr;
  SparseHessian* hessian = nullptr;            ///< the Model's pattern, assembled into
  const std::vector<char>* pinned = nullptr;  ///< per DOF: eliminated (keeps its value)
  double stepTolerance = 0.0;                 ///< m: criterion (a)
  /// Criterion (b): the unbalanced forces at an iterate, and the largest relative one allowed.
  std::function<ForceResidual(const NewtonIterate&)> residual;
  double residualTolerance = 0.0;
};

struct NewtonOutcome {
  bool ok = true;
  std::string error;      ///< why it failed
  bool forces = false;    ///< the failure is about unbalanced forces: report them with it
  int iterations = 0;
  int backtracks = 0;
  NewtonTimes times;
};

class NewtonSolver {
 public:
  explicit NewtonSolver(NewtonSettings settings)
      : settings_(settings), search_(LineSearchSettings{settings.maxBacktracks, settings.armijo}) {}
  const NewtonSettings& settings() const { return settings_; }
  /// The linear solver in use (null before the first solve).
  const LinearSolver* linearSolver() const { return solver_.get(); }
  /// Drops the factorisation (the pattern changed).
  void invalidate() { solver_.reset(); }
  /// Newton's iterations from `it` (evaluated there) until converged; `it` ends at the last
  /// accepted iterate.
  NewtonOutcome solve(const NewtonProblem& problem, NewtonIterate& it);

 private:
  /// Assembles the system at it.x and solves it for dx_.
  bool newtonStep(const NewtonProblem& problem, const NewtonIterate& it, NewtonTimes& times);
  /// Largest |g_i| / (m_i g c^2) over free DOFs: the merit of the round-off fallback.
  double relativeGradient(const NewtonProblem& problem, const VectorX& g) const;

  NewtonSettings settings_;
  std::unique_ptr<LinearSolver> solver_;
  LineSearch search_;
  VectorX dx_, rhs_;
  std::vector<Eigen::Triplet<double>> outsidePattern_;
  LinearSolver::Matrix extra_, system_;
};

}  // namespace fem_cloth
