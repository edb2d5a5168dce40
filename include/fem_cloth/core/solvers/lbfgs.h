// L-BFGS on an incremental potential (potential/incremental_potential.h) with a prefactored
// constant initial Hessian (Liu, Bouaziz & Kavan, "Quasi-Newton Methods for Real-Time Simulation
// of Hyperelastic Materials", ACM TOG 2017): the quasi-Newton solver beside solvers/newton.h.
//
// Each iteration takes the direction dx = -H g, g = dPhi/dx on the free DOFs, H the L-BFGS
// inverse Hessian: the two-loop recursion (LbfgsHistory, Nocedal & Wright, "Numerical
// Optimization", algorithm 7.4) over the last `memory` curvature pairs (s, y) = (the move, the
// change of g it made), on the initial inverse H0 = B0^-1, one back-substitution with a matrix
// factorised once (solvers/initial_hessian.h). No Hessian is assembled and nothing is factorised
// per iteration. The step then goes through the same line search as Newton's (solvers/
// line_search.h: the collision step bound, Armijo backtracking, the round-off merit). A pair
// that carries no curvature (s.y <= 0) is dropped; a direction that does not descend, or along
// which the search finds no decrease, restarts the history from -B0^-1 g.
//
// Converged by the same acceptance as Newton (NewtonProblem::error, test (a) in displacement):
// after each move the direction for the next iteration, dx = -H g at the new iterate, is the
// estimate of the distance to the minimum (B = H^-1 is the quasi-Newton model of the Hessian,
// exact on the pairs' span), scaled by 1 / (1 - theta), theta = |dx| / |the move that reached the
// iterate| (remainingErrorFactor, acceptance.h), since L-BFGS converges only (super)linearly. The
// test so costs nothing extra: its dx is the next step. It is the solver's stopping rule, not the
// acceptance: outside the pairs' span H is B0^-1, the rest stiffness, which understates the
// distance to the minimum where the cloth is softer than at rest (out of plane, in bending; about
// 100 x on config/flag.yaml), so the caller confirms the solution with Newton's correction there
// (ImplicitIntegrator::solve, NewtonSolver::solve's acceptAtStart).
//
// It fails (the caller falls back to projected Newton for the substep) when it has not converged
// in maxIterations, or when the line search finds no decrease even from the restarted direction.
#pragma once

#include <string>
#include <vector>

#include "fem_cloth/core/solvers/initial_hessian.h"
#include "fem_cloth/core/solvers/newton.h"

namespace fem_cloth {

/// The curvature pairs of L-BFGS and the two-loop recursion.
class LbfgsHistory {
 public:
  explicit LbfgsHistory(int memory = 8) : s_(memory), y_(memory), rho_(memory), alpha_(memory) {}
  int memory() const { return static_cast<int>(s_.size()); }
  int stored() const { return stored_; }
  void clear() { stored_ = 0; }
  /// Stores the pair s = xNew - xOld, y = gNew - gOld (the oldest goes when full) if it carries
  /// curvature, s.y > 0; returns whether it did.
  bool add(const VectorX& xNew, const VectorX& xOld, const VectorX& gNew, const VectorX& gOld);
  /// out = H q, H the L-BFGS inverse Hessian on H0, applyH0(v, z) setting z = H0 v.
  template <class ApplyH0>
  void apply(const VectorX& q, ApplyH0&& applyH0, VectorX& out);

 private:
  int slot(int k) const { return (newest_ - k + memory()) % memory(); }  ///< k-th newest
  std::vector<VectorX> s_, y_;
  std::vector<double> rho_, alpha_;
  VectorX sNew_, yNew_, scratch_;
  int stored_ = 0, newest_ = -1;
};

template <class ApplyH0>
void LbfgsHistory::apply(const VectorX& q, ApplyH0&& applyH0, VectorX& out) {
  scratch_ = q;
  for (int k = 0; k < stored_; ++k) {
    const int i = slot(k);
    alpha_[i] = rho_[i] * s_[i].dot(scratch_);
    scratch_ -= alpha_[i] * y_[i];
  }
  applyH0(scratch_, out);
  for (int k = stored_ - 1; k >= 0; --k) {
    const int i = slot(k);
    const double beta = rho_[i] * y_[i].dot(out);
    out += (alpha_[i] - beta) * s_[i];
  }
}

struct QuasiNewtonSettings {
  int memory = 8;           ///< curvature pairs kept
  int maxIterations = 100;  ///< per substep, before the caller falls back to Newton
  InitialHessian::ContactOptions contact;  ///< how the contact's blocks enter H0
};

class QuasiNewtonSolver {
 public:
  QuasiNewtonSolver(QuasiNewtonSettings settings, LineSearchSettings search)
      : settings_(settings), history_(settings.memory), search_(search) {}
  const QuasiNewtonSettings& settings() const { return settings_; }
  /// L-BFGS iterations from `it` (evaluated there) until converged, with `initial` prepared for
  /// the substep; `it` ends at the last accepted iterate (evaluated), also on failure.
  NewtonOutcome solve(const NewtonProblem& problem, InitialHessian& initial, NewtonIterate& it);

 private:
  /// dx_ = -H g_ (g_: dPhi/dx with pinned DOFs zeroed).
  void direction(InitialHessian& initial, NewtonTimes& times);
  /// The error at `it` with dx_ the correction still to make, after a move `moved` long.
  bool converged(const NewtonProblem& problem, const NewtonIterate& it, double moved, NewtonOutcome& outcome);
  /// g_ from it.gradient, pinned DOFs zeroed.
  void freeGradient(const NewtonProblem& problem, const NewtonIterate& it);

  QuasiNewtonSettings settings_;
  LbfgsHistory history_;
  LineSearch search_;
  VectorX g_, gOld_, xOld_, dx_;
};

}  // namespace fem_cloth
