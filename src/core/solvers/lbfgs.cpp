#include "fem_cloth/core/solvers/lbfgs.h"

#include <chrono>
#include <limits>
#include <sstream>

namespace fem_cloth {

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point& since) {
  const Clock::time_point now = Clock::now();
  const double s = std::chrono::duration<double>(now - since).count();
  since = now;
  return s;
}

}  // namespace

bool LbfgsHistory::add(const VectorX& xNew, const VectorX& xOld, const VectorX& gNew,
                       const VectorX& gOld) {
  sNew_ = xNew - xOld;
  yNew_ = gNew - gOld;
  const double sy = sNew_.dot(yNew_);
  if (!(sy > 0.0)) return false;
  newest_ = (newest_ + 1) % memory();
  s_[newest_].swap(sNew_);
  y_[newest_].swap(yNew_);
  rho_[newest_] = 1.0 / sy;
  stored_ = std::min(stored_ + 1, memory());
  return true;
}

void QuasiNewtonSolver::freeGradient(const NewtonProblem& problem, const NewtonIterate& it) {
  const std::vector<char>& pinned = *problem.pinned;
  g_ = it.gradient;
  for (Index i = 0; i < g_.size(); ++i) {
    if (pinned[i]) g_[i] = 0.0;
  }
}

void QuasiNewtonSolver::direction(InitialHessian& initial, NewtonTimes& times) {
  Clock::time_point clock = Clock::now();
  history_.apply(g_, [&initial](const VectorX& q, VectorX& z) { initial.applyInverse(q, z); }, dx_);
  dx_ = -dx_;
  times.solve += secondsSince(clock);
}

bool QuasiNewtonSolver::converged(const NewtonProblem& problem, const NewtonIterate& it,
                                  double moved, NewtonOutcome& outcome) {
  outcome.displacement = problem.error(it, dx_);
  outcome.displacement.scale(remainingErrorFactor(dx_.norm(), moved));
  return outcome.displacement.within();
}

NewtonOutcome QuasiNewtonSolver::solve(const NewtonProblem& problem, InitialHessian& initial,
                                       NewtonIterate& it) {
  IncrementalPotential& potential = *problem.potential;
  NewtonOutcome outcome;
  auto fail = [&](const std::string& what) {
    outcome.ok = false;
    outcome.error = what;
    outcome.forces = true;
    return outcome;
  };
  auto merit = [&problem](const VectorX& g) { return relativeGradient(problem, g); };
  history_.clear();
  freeGradient(problem, it);
  direction(initial, outcome.times);
  while (true) {
    if (outcome.iterations >= settings_.maxIterations) {
      std::ostringstream msg;
      msg << "L-BFGS did not converge in " << outcome.iterations << " iterations";
      const DisplacementError& e = outcome.displacement;
      if (e.measured()) {
        msg << " (vertex " << e.vertex << " is left with a displacement error of " << e.error
            << " m against its tolerance " << e.tolerance << " m)";
      }
      return fail(msg.str());
    }
    ++outcome.iterations;
    if (!(g_.dot(dx_) < 0.0)) {
      // Not a descent direction (round-off in the pairs): restart from -B0^-1 g, which is one.
      history_.clear();
      direction(initial, outcome.times);
    }
    xOld_ = it.x;
    gOld_ = g_;
    Clock::time_point clock = Clock::now();
    const double maxStep = search_.bound(potential, it.x, dx_).whole;
    outcome.times.bound += secondsSince(clock);
    double moved = 0.0;
    if (dx_.cwiseAbs().maxCoeff() <= problem.stepTolerance && maxStep >= 1.0) {
      // A step shorter than the tolerance: taken whole (if it stays in the domain), as Newton
      // does, without a line search that would only compare round-off.
      TermsEvaluation trial;
      if (search_.evaluateFullStep(potential, it, dx_, trial)) {
        it.terms = trial;
        search_.moveToTrial(potential, it);
        it.phi = potential.value(it.x, it.terms);
        moved = dx_.norm();
      }
    } else {
      const LineSearch::Outcome found = search_.search(potential, dx_, it, merit);
      outcome.backtracks += found.backtracks;
      if (found.moved) moved = found.fraction * dx_.norm();
    }
    outcome.times.search += secondsSince(clock);
    if (moved == 0.0) {
      // No decrease along dx: at the minimum to round-off if the error is small; else once more
      // from -B0^-1 g, and if even that finds none, fail.
      if (converged(problem, it, 0.0, outcome)) break;
      if (history_.stored() == 0) {
        std::ostringstream msg;
        msg << "the line search found no decrease of the incremental potential after "
            << search_.settings().maxBacktracks << " backtracks";
        return fail(msg.str());
      }
      history_.clear();
      direction(initial, outcome.times);
      continue;
    }
    freeGradient(problem, it);
    history_.add(it.x, xOld_, g_, gOld_);
    if (!initial.refreshContact(it.x)) return fail("the initial Hessian with the contact blocks could not be factorised");
    direction(initial, outcome.times);
    if (converged(problem, it, moved, outcome)) break;
  }
  if (!it.x.allFinite()) {
    outcome.ok = false;
    outcome.error = "the L-BFGS iterate became non-finite";
  }
  return outcome;
}

}  // namespace fem_cloth
