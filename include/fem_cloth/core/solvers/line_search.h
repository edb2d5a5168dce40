// The search along a descent direction of the incremental potential Phi, shared by its solvers
// (solvers/newton.h; any other minimiser of Phi): how far the step may go, and how much of it to
// take.
//
// How far: the step-bounding terms of Phi (continuous collision detection of the contact) find,
// for x + t dx, the largest collision-free t (one fraction for the whole step) and, on request,
// per DOF the fraction of the step at which a constraint of that DOF alone would stop it
// (StepBound::perDof; IncrementalPotential::prepareStep). The search takes at most the whole
// step's fraction; a solver that scales DOFs by different fractions (a filtered step) checks
// the step it builds with bound() again.
//
// How much: backtracking (Armijo) on Phi, halving the step until Phi decreases enough; states
// outside a term's domain have Phi = +inf and always backtrack. Close to the minimum the decrease
// a step makes falls below the round-off of Phi itself; there the largest unbalanced force, which
// has no such cancellation, is the merit instead (see search()).
#pragma once

#include <limits>

#include "fem_cloth/core/potential/incremental_potential.h"

namespace fem_cloth {

/// How far a step may go: what the step-bounding terms of Phi found for x + t dx.
struct StepBound {
  double whole = 1.0;  ///< the largest collision-free t in [0, 1] for the whole step
  /// Per DOF, when bound() was asked for it (else empty): the smallest t in [whole, 1] at which
  /// a constraint the DOF takes part in (a vertex and an obstacle, a self-contact pair) would
  /// stop the step; 1 where none does.
  VectorX perDof;
};

struct LineSearchSettings {
  int maxBacktracks = 40;
  double armijo = 1e-4;  ///< sufficient-decrease constant
};

/// A point of the minimisation, with everything known there.
struct PotentialIterate {
  VectorX x;             ///< positions (m)
  VectorX termGradient;  ///< gradient of the conservative and load terms
  VectorX gradient;      ///< dPhi/dx
  TermsEvaluation terms;
  double phi = 0.0;
};

class LineSearch {
 public:
  explicit LineSearch(LineSearchSettings settings = {}) : settings_(settings) {}
  const LineSearchSettings& settings() const { return settings_; }

  /// Readies Phi's step-bounding terms for x + t dx (their broad phase) and measures how far
  /// the step may go, per DOF too if `perDof`; without such terms the whole step is free.
  const StepBound& bound(IncrementalPotential& potential, const VectorX& x, const VectorX& dx,
                         bool perDof = false);
  const StepBound& lastBound() const { return bound_; }

  struct Outcome {
    bool moved = false;      ///< the iterate moved to a point of lower merit
    double fraction = 0.0;   ///< of dx taken
    int backtracks = 0;
  };
  /// Searches along dx from `it` (evaluated there), at most bound().whole of it; on success `it`
  /// moves there and is evaluated (positions, terms, Phi, gradient). `relativeGradient`
  /// measures the unbalanced force at a gradient (the round-off merit: smaller is better).
  template <class RelativeGradient>
  Outcome search(IncrementalPotential& potential, const VectorX& dx, PotentialIterate& it,
                 RelativeGradient relativeGradient);

  /// `it` takes the trial point (positions and term gradient) of the last search, and its
  /// dPhi/dx.
  void moveToTrial(IncrementalPotential& potential, PotentialIterate& it);
  /// Evaluates the terms at it.x + dx into the trial; true if it is inside the domain.
  bool evaluateFullStep(IncrementalPotential& potential, const PotentialIterate& it, const VectorX& dx,
                        TermsEvaluation& trial);

 private:
  /// The round-off regime: true if the full step lowers the unbalanced force (trial evaluated).
  template <class RelativeGradient>
  bool roundOffStep(IncrementalPotential& potential, const VectorX& dx, PotentialIterate& it,
                    RelativeGradient& relativeGradient);

  LineSearchSettings settings_;
  StepBound bound_;
  VectorX xTrial_, gTrial_, termGradientTrial_;
};

template <class RelativeGradient>
bool LineSearch::roundOffStep(IncrementalPotential& potential, const VectorX& dx,
                              PotentialIterate& it, RelativeGradient& relativeGradient) {
  TermsEvaluation trial;
  if (!evaluateFullStep(potential, it, dx, trial)) return false;
  potential.gradient(xTrial_, termGradientTrial_, gTrial_);
  if (!(relativeGradient(gTrial_) < relativeGradient(it.gradient))) return false;
  it.terms = trial;
  it.phi = potential.value(xTrial_, trial);
  return true;
}

template <class RelativeGradient>
LineSearch::Outcome LineSearch::search(IncrementalPotential& potential, const VectorX& dx,
                                       PotentialIterate& it, RelativeGradient relativeGradient) {
  Outcome out;
  const double slope = it.gradient.dot(dx);
  const double maxStep = bound_.whole;
  // Close to the minimum the decrease a step makes, about -slope/2 (Newton decrement), falls
  // below the round-off of Phi itself, which is of order eps times the magnitudes of its terms.
  // Comparing Phi values there only compares noise: the search accepts tiny random steps and the
  // solver stalls just above a tight tolerance (and more so after a rollback, since the
  // decrement scales with c^4 and Phi with c^2). There the force residual, which has no such
  // cancellation, is the merit function instead: the full step is taken if it lowers it.
  const double phiScale = potential.roundoff(it.phi, it.terms);
  if (-slope <= 1e3 * std::numeric_limits<double>::epsilon() * phiScale && maxStep >= 1.0 &&
      roundOffStep(potential, dx, it, relativeGradient)) {
    out.moved = true;
    out.fraction = 1.0;
  } else {
    double step = maxStep;
    for (int b = 0; b <= settings_.maxBacktracks && !out.moved; ++b) {
      xTrial_ = it.x + step * dx;
      const TermsEvaluation trial = potential.evaluateTerms(xTrial_, &termGradientTrial_);
      const double phiTrial = trial.inDomain ? potential.value(xTrial_, trial) : kInfiniteEnergy;
      if (phiTrial <= it.phi + settings_.armijo * step * slope) {
        it.phi = phiTrial;
        it.terms = trial;
        out.moved = true;
        out.fraction = step;
      } else {
        ++out.backtracks;
        step *= 0.5;
      }
    }
  }
  if (out.moved) moveToTrial(potential, it);
  return out;
}

}  // namespace fem_cloth
