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
// Converged when the error left is small enough for the caller (acceptance test (a) in
// displacement): after each move the factorisation in hand (the Hessian of the iterate before)
// turns the gradient at the new iterate into the correction dx = -H^-1 dPhi/dx that Newton would
// make next, which is the distance to the minimum to first order (Newton converges
// quadratically, so H of the iterate before serves as well as its own) and costs one pair of
// triangular solves, not a factorisation. Where the iterations converge only linearly, the
// correction is scaled by 1 / (1 - theta), theta its ratio to the move before
// (remainingErrorFactor()); an iterate is accepted only if the move before it contracted too
// (theta < 1), since a single contracting move after a diverging one shows no contraction. A
// failed solve leaves the iterate where it stopped: the caller rolls back.
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
  /// A Newton step shorter than tolerance x the rest bounding-box diagonal x h (a velocity in
  /// cloth sizes per second; 1.4e-5 m per 0.01 s step on a 1 m cloth) is taken whole, without a
  /// line search, whose test of Phi would compare round-off there.
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
  double stepTolerance = 0.0;                 ///< m: NewtonSettings::tolerance
  /// The error of an iterate whose remaining correction (per DOF, zero on pinned ones) is dx:
  /// converged when its relative value is at most 1.
  std::function<DisplacementError(const NewtonIterate&, const VectorX& dx)> error;
};

struct NewtonOutcome {
  bool ok = true;
  std::string error;      ///< why it failed
  bool forces = false;    ///< the failure is about unbalanced forces: report them with it
  DisplacementError displacement;  ///< the error last measured (not measured: no move yet)
  int iterations = 0;
  int backtracks = 0;
  NewtonTimes times;
};

/// Largest |g_i| / (m_i g c^2) over the free DOFs of a gradient g of Phi: the merit of the line
/// search's round-off regime (LineSearch::search), for every solver of a NewtonProblem.
double relativeGradient(const NewtonProblem& problem, const VectorX& g);

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
  /// accepted iterate. acceptAtStart: `it` is a candidate solution (another solver's), accepted
  /// without a move when the first Newton correction, by the projected Hessian assembled and
  /// factorised at `it`, is within the tolerance; else Newton goes on from there with it.
  NewtonOutcome solve(const NewtonProblem& problem, NewtonIterate& it, bool acceptAtStart = false);

 private:
  /// Assembles the system at it.x and solves it for dx_.
  bool newtonStep(const NewtonProblem& problem, const NewtonIterate& it, NewtonTimes& times);
  /// The error at `it` by the factorisation in hand (into outcome.displacement), the move that
  /// reached `it` being `moved` long (m, 2-norm; 0: none); true if small enough.
  bool converged(const NewtonProblem& problem, const NewtonIterate& it, double moved, NewtonOutcome& outcome);

  NewtonSettings settings_;
  std::unique_ptr<LinearSolver> solver_;
  LineSearch search_;
  VectorX dx_, rhs_, correction_;
  double lastTheta_ = 0.0;  ///< the contraction (correction / move) converged() last measured
  std::vector<Eigen::Triplet<double>> outsidePattern_;
  LinearSolver::Matrix extra_, system_;
};

}  // namespace fem_cloth
