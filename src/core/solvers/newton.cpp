#include "fem_cloth/core/solvers/newton.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

namespace fem_cloth {

namespace {

using Matrix = LinearSolver::Matrix;
using Clock = std::chrono::steady_clock;

/// Iterations, simplified ones included, per factorised iteration allowed (NewtonSettings::maxIterations).
constexpr int kChordIterationsFactor = 4;
/// A simplified step is lengthened by 1 / (1 - theta) (at most kMaxExtrapolation) when the
/// contraction theta is above kExtrapolateFrom and within kSteadyContraction of the one before.
constexpr double kExtrapolateFrom = 0.5;
constexpr double kSteadyContraction = 0.05;
constexpr double kMaxExtrapolation = 10.0;
/// A correction at most this fraction of its tolerance is accepted after a move that did not
/// contract (converged()).
constexpr double kNegligibleError = 1e-2;

/// Adds the time since `since` to `into` and restarts it (s).
void lap(Clock::time_point& since, double& into) {
  const Clock::time_point now = Clock::now();
  into += std::chrono::duration<double>(now - since).count();
  since = now;
}

// Replaces the rows and columns of pinned DOFs by the identity scaled by the DOF's mass, so
// that the pattern is unchanged and the solve leaves pinned DOFs where they are.
void filterPinned(Matrix& A, const std::vector<char>& pinned, const VectorX& mass) {
  double* values = A.valuePtr();
  const int* outer = A.outerIndexPtr();
  const int* inner = A.innerIndexPtr();
  for (Eigen::Index j = 0; j < A.outerSize(); ++j) {
    const bool pinnedColumn = pinned[j] != 0;
    for (int k = outer[j]; k < outer[j + 1]; ++k) {
      const int i = inner[k];
      if (pinnedColumn || pinned[i]) values[k] = (i == j) ? mass[i] : 0.0;
    }
  }
}

}  // namespace

double relativeGradient(const NewtonProblem& problem, const VectorX& g) {
  const std::vector<char>& pinned = *problem.pinned;
  const VectorX& mass = problem.potential->mass();
  double worst = 0.0;
  for (Index i = 0; i < g.size(); ++i) {
    if (!pinned[i]) worst = std::max(worst, std::abs(g[i]) / (mass[i] * kStandardGravity));
  }
  return worst / problem.potential->c2();
}

bool NewtonSolver::converged(const NewtonProblem& problem, const NewtonIterate& it, double moved,
                             NewtonOutcome& outcome) {
  Clock::time_point clock = Clock::now();
  const std::vector<char>& pinned = *problem.pinned;
  rhs_ = -it.gradient;
  for (Index i = 0; i < rhs_.size(); ++i) {
    if (pinned[i]) rhs_[i] = 0.0;
  }
  correction_.setZero(rhs_.size());
  const bool solved = solver_->solve(rhs_, correction_);
  lap(clock, outcome.times.solve);
  if (!solved) return false;
  // Where Newton converges only linearly, the corrections still to come add up (acceptance.h).
  // After an extrapolated simplified step, the move was lengthened to 1 / (1 - theta) corrections
  // on the contraction theta measured before it, so the correction left says nothing of the
  // iteration's contraction (traced, 9x9 hanging cloth, backward Euler, dt 100 s: theta 0.06
  // after a 4.66x step, accepted with 4.05x the promised error): that contraction stands.
  outcome.displacement = problem.error(it, correction_);
  const DisplacementError& e = outcome.displacement;
  const bool negligible = e.relative <= kNegligibleError && e.energy <= kNegligibleError * e.energyTolerance;
  const double corrected = correction_.norm();
  const double theta = moved > 0.0 ? corrected / moved : 0.0;
  contraction_ = extrapolatedMove_ ? std::max(theta, lastTheta_) : theta;
  outcome.displacement.scale(moved > 0.0 ? remainingErrorFactor(contraction_, 1.0) : 1.0);
  // The correction is a descent direction by the factorisation in hand: the next step
  // (simplified Newton), unless that matrix has stopped contracting the error. Where the
  // contraction theta holds steady (a slow mode the projected Hessian overstates: compressed
  // cloth, whose negative curvature the projection clamps), the corrections still to come add up
  // to 1 / (1 - theta) of this one, mostly along it: the step goes that far (the line search
  // backtracks if Phi does not decrease). Only while the iteration contracts: this move and the
  // one before (a simplified step after a move that did not contract, at dt 10 s, needed a new
  // factorisation after nearly every one and drove the iterate away).
  chord_ = settings_.chordContraction > 0.0 && moved > 0.0 && theta <= settings_.chordContraction &&
           lastTheta_ <= settings_.chordContraction;
  extrapolate_ = 1.0;
  if (chord_ && theta > kExtrapolateFrom && std::abs(theta - lastTheta_) < kSteadyContraction) {
    extrapolate_ = std::min(1.0 / (1.0 - theta), kMaxExtrapolation);
  }
  // 1 / (1 - theta) estimates the error left only where the iteration contracts: one move that
  // contracts right after one that did not (theta >= 1) shows no such thing (traced, dt 10 s with
  // simplified steps: theta 0.42 right after 11.3 and 4.47 was accepted, its true error 5.34x
  // the bound; on main, theta 0.30 after 52 happened to be 0.25x). Not accepted: the next move
  // measures again. Unless the correction is negligible (the moves of round-off, as in a rigid
  // fall, have theta about 1 forever): the projected Hessian understated the error 20x at most
  // in those traces.
  const bool contracting = lastTheta_ < 1.0 || negligible;
  lastTheta_ = theta;
  lastMoved_ = moved;
  return contracting && outcome.displacement.within();
}

bool NewtonSolver::newtonStep(const NewtonProblem& problem, const NewtonIterate& it, NewtonTimes& times) {
  Clock::time_point clock = Clock::now();
  const std::vector<char>& pinned = *problem.pinned;
  const VectorX& mass = problem.potential->mass();
  const Index n = it.x.size();
  if (solver_ == nullptr) solver_ = makeLinearSolver(settings_.linear, n);
  problem.potential->hessian(it.x, *problem.hessian, outsidePattern_);
  // Entries outside the Model's pattern (self-contact) make a system of their own.
  Matrix* system = &problem.hessian->matrix();
  if (!outsidePattern_.empty()) {
    extra_.resize(n, n);
    extra_.setFromTriplets(outsidePattern_.begin(), outsidePattern_.end());
    system_ = problem.hessian->matrix() + extra_;
    system = &system_;
  }
  filterPinned(*system, pinned, mass);
  rhs_ = -it.gradient;
  for (Index i = 0; i < n; ++i) {
    if (pinned[i]) rhs_[i] = 0.0;
  }
  dx_.setZero(n);
  lap(clock, times.assembly);
  const bool factorised = solver_->compute(*system);
  lap(clock, times.factorisation);
  const bool solved = factorised && solver_->solve(rhs_, dx_);
  lap(clock, times.solve);
  return solved;
}

bool NewtonSolver::confirmed(const NewtonProblem& problem, const NewtonIterate& it, NewtonOutcome& outcome) {
  if (!simplifiedMove_) return true;  // the factorisation is the iterate before's: as trusted as Newton's
  // Measured by a factorisation older than the iterate before, the correction may understate the
  // error (a huge step, whose Hessian changes from iterate to iterate): the Newton correction by
  // the projected Hessian at `it` itself decides; if it is too large, it is the next step.
  ++outcome.iterations;
  if (!newtonStep(problem, it, outcome.times)) {
    outcome.ok = false;
    outcome.error = "the linear solve (" + solver_->name() + ") failed";
    return true;
  }
  outcome.displacement = problem.error(it, dx_);
  const double theta = lastMoved_ > 0.0 ? dx_.norm() / lastMoved_ : 0.0;
  outcome.displacement.scale(remainingErrorFactor(std::max(theta, contraction_), 1.0));
  if (outcome.displacement.within()) return true;
  chord_ = false;
  pending_ = true;
  return false;
}

NewtonOutcome NewtonSolver::solve(const NewtonProblem& problem, NewtonIterate& it, bool acceptAtStart) {
  IncrementalPotential& potential = *problem.potential;
  const double h = potential.frame().h;
  const double stepTolerance = problem.stepTolerance;
  NewtonOutcome outcome;
  double lastStep = std::numeric_limits<double>::infinity();
  auto fail = [&](const std::string& what) {
    outcome.ok = false;
    outcome.error = what;
    outcome.forces = true;
    return outcome;
  };
  chord_ = pending_ = false;
  lastTheta_ = contraction_ = 0.0;
  while (true) {
    // maxIterations bounds the factorised iterations; the cheap simplified ones, up to
    // kChordIterationsFactor times as many in all.
    if (outcome.iterations - outcome.chordSteps >= settings_.maxIterations ||
        outcome.iterations >= kChordIterationsFactor * settings_.maxIterations) {
      std::ostringstream msg;
      msg << "Newton did not converge in " << outcome.iterations << " iterations (" << outcome.chordSteps
          << " of them with an earlier factorisation; last step "
          << lastStep / h << " m/s";
      const DisplacementError& e = outcome.displacement;
      if (e.measured() && !(e.relative <= 1.0)) {
        msg << "; vertex " << e.vertex << " is left with a displacement error of " << e.error
            << " m against its tolerance " << e.tolerance << " m";
      } else if (e.measured()) {
        msg << "; the correction left would change the step's energy by " << e.energy << " J against its tolerance "
            << e.energyTolerance << " J";
      }
      msg << ")";
      return fail(msg.str());
    }
    simplifiedMove_ = chord_;
    extrapolatedMove_ = chord_ && !pending_ && extrapolate_ != 1.0;
    if (pending_) {
      pending_ = false;  // dx_: the Newton step confirmed() solved for
    } else if (++outcome.iterations; chord_) {
      dx_.swap(correction_);  // the simplified Newton step (converged() solved for it)
      if (extrapolate_ != 1.0) dx_ *= extrapolate_;
      ++outcome.chordSteps;
    } else if (!newtonStep(problem, it, outcome.times)) {
      outcome.ok = false;
      outcome.error = "the linear solve (" + solver_->name() + ") failed";
      return outcome;
    }
    if (acceptAtStart && outcome.iterations == 1) {
      // The check of another solver's solution: the Newton correction by the Hessian at `it`
      // itself is the distance to the minimum to first order; if it is small enough, stop there.
      outcome.displacement = problem.error(it, dx_);
      if (outcome.displacement.within()) break;
    }
    const double stepLength = dx_.cwiseAbs().maxCoeff();
    lastStep = stepLength;
    // The step may go only as far as the step-bounding terms (CCD) find safe.
    Clock::time_point clock = Clock::now();
    const double maxStep = search_.bound(potential, it.x, dx_).whole;
    lap(clock, outcome.times.bound);
    if (stepLength <= stepTolerance && maxStep >= 1.0) {
      // A Newton step shorter than the tolerance: take it (if it stays in the domain) without a
      // line search, whose test would only compare round-off; stop if the error is small.
      TermsEvaluation trial;
      if (search_.evaluateFullStep(potential, it, dx_, trial)) {
        it.terms = trial;
        search_.moveToTrial(potential, it);
        it.phi = potential.value(it.x, it.terms);
      }
      lap(clock, outcome.times.search);
      if (converged(problem, it, dx_.norm(), outcome) && confirmed(problem, it, outcome)) break;
      continue;
    }
    const LineSearch::Outcome found = search_.search(
        potential, dx_, it, [&problem](const VectorX& g) { return relativeGradient(problem, g); });
    outcome.backtracks += found.backtracks;
    lap(clock, outcome.times.search);
    if (!found.moved) {
      // No measurable decrease of Phi: at its minimum to round-off, if the error is small.
      if (converged(problem, it, 0.0, outcome) && confirmed(problem, it, outcome)) break;
      if (simplifiedMove_) continue;  // a new factorisation next (converged() left chord_ false)
      std::ostringstream msg;
      msg << "the line search found no decrease of the incremental potential after "
          << settings_.maxBacktracks << " backtracks";
      return fail(msg.str());
    }
    if (converged(problem, it, found.fraction * dx_.norm(), outcome) && confirmed(problem, it, outcome)) break;
  }
  if (!outcome.ok) return outcome;
  if (!it.x.allFinite()) {
    outcome.ok = false;
    outcome.error = "the Newton iterate became non-finite";
  }
  return outcome;
}

}  // namespace fem_cloth
