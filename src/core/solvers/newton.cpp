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
  outcome.displacement = problem.error(it, correction_);
  const DisplacementError& e = outcome.displacement;
  const bool negligible = e.relative <= kNegligibleError && e.energy <= kNegligibleError * e.energyTolerance;
  outcome.displacement.scale(remainingErrorFactor(correction_.norm(), moved));
  // 1 / (1 - theta) estimates the error left only where the iteration contracts: one move that
  // contracts right after one that did not (theta >= 1) shows no such thing (traced, 9x9 hanging
  // cloth, backward Euler, dt 10 s: theta 0.30 right after 52 was accepted, 0.25x the promised
  // error by luck; with simplified Newton steps, branch newt43, theta 0.42 after 11.3 and 4.47
  // was 5.34x). Not accepted: the next move measures again. Unless the correction is negligible
  // (the moves of round-off, as in a rigid fall, have theta about 1 forever).
  const bool contracting = lastTheta_ < 1.0 || negligible;
  lastTheta_ = moved > 0.0 ? correction_.norm() / moved : 0.0;
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
  lastTheta_ = 0.0;
  while (true) {
    if (outcome.iterations >= settings_.maxIterations) {
      std::ostringstream msg;
      msg << "Newton did not converge in " << outcome.iterations << " iterations (last step "
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
    ++outcome.iterations;
    if (!newtonStep(problem, it, outcome.times)) {
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
      if (converged(problem, it, dx_.norm(), outcome)) break;
      continue;
    }
    const LineSearch::Outcome found = search_.search(
        potential, dx_, it, [&problem](const VectorX& g) { return relativeGradient(problem, g); });
    outcome.backtracks += found.backtracks;
    lap(clock, outcome.times.search);
    if (!found.moved) {
      // No measurable decrease of Phi: at its minimum to round-off, if the error is small.
      if (converged(problem, it, 0.0, outcome)) break;
      std::ostringstream msg;
      msg << "the line search found no decrease of the incremental potential after "
          << settings_.maxBacktracks << " backtracks";
      return fail(msg.str());
    }
    if (converged(problem, it, found.fraction * dx_.norm(), outcome)) break;
  }
  if (!it.x.allFinite()) {
    outcome.ok = false;
    outcome.error = "the Newton iterate became non-finite";
  }
  return outcome;
}

}  // namespace fem_cloth
