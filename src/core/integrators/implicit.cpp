#include "fem_cloth/core/integrators/implicit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "fem_cloth/core/air.h"
#include "fem_cloth/core/contact/contact_model.h"
#include "fem_cloth/core/integrators/step_common.h"

namespace fem_cloth {

Expected<ImplicitSolver> parseImplicitSolver(const std::string& name) {
  if (name == "newton") return ImplicitSolver::Newton;
  if (name == "lbfgs") return ImplicitSolver::Lbfgs;
  return Error{"unknown solver '" + name + "' (known: newton, lbfgs)"};
}

std::string implicitSolverName(ImplicitSolver kind) {
  return kind == ImplicitSolver::Lbfgs ? "lbfgs" : "newton";
}

bool solvesByLbfgs(const Integrator& integrator) {
  const auto* implicit = dynamic_cast<const ImplicitIntegrator*>(&integrator);
  return implicit != nullptr && implicit->solver() == ImplicitSolver::Lbfgs;
}

ImplicitIntegrator::ImplicitIntegrator(ImplicitScheme scheme, NewtonSettings settings,
                                       ImplicitSolverSettings solver)
    : scheme_(scheme),
      newton_(settings),
      solverKind_(solver.kind),
      lbfgs_(solver.lbfgs, LineSearchSettings{settings.maxBacktracks, settings.armijo}) {}

std::string ImplicitIntegrator::name() const {
  return scheme_ == ImplicitScheme::BackwardEuler ? "backward_euler" : "bdf2";
}

ForceResidual ImplicitIntegrator::residual(const StepInput& input, const State& state, double h,
                                           const NewtonIterate& it) {
  // The equations of motion hold where dPhi/dx = 0; dPhi/dx / c^2 is the unbalanced force (N).
  unbalancedForce_ = it.gradient / potential_.c2();
  velocity_ = potential_.gamma() * (it.x - potential_.xc());
  return measureResidual(unbalancedForce_, potential_.mass(), *input.externalForce, *pinned_,
                         state.v, velocity_, h, input.residualScale.acceleration);
}

DisplacementError ImplicitIntegrator::displacementError(const StepInput& input, const State& state,
                                                       double h, const NewtonIterate& it,
                                                       const VectorX& dx) {
  velocity_ = potential_.gamma() * (it.x - potential_.xc());
  SubstepMotion motion;
  motion.xStart = &state.x;
  motion.xEnd = &it.x;
  motion.vStart = &state.v;
  motion.vEnd = &velocity_;
  motion.vBefore = potential_.isBdf2() ? &state.vPrevious : nullptr;
  motion.h = h;
  DisplacementError error = measureDisplacementError(dx, motion, *pinned_, model_->dim(), input.displacement);
  // The energy the correction would change, E = 1/2 v+^T M v+ + U(x): dE/dx = gamma M v+ +
  // dU/dx, with c^2 dU/dx = dPhi/dx - M (x - xhat) (incremental_potential.h), and its Hessian
  // H / c^2 (gamma^2 = 1 / c^2 for both schemes): to second order the change is
  // dE/dx . dx + 1/2 dx^T H dx / c^2, where dx^T H dx = -dPhi/dx . dx for the Newton correction.
  if (std::isfinite(input.energyBudget)) {
    const std::vector<char>& pinned = *pinned_;
    const VectorX& mass = potential_.mass();
    const VectorX& xhat = potential_.xhat();
    const double gamma = potential_.gamma(), c2 = potential_.c2();
    double first = 0.0, decrement = 0.0;
    for (Index i = 0; i < dx.size(); ++i) {
      if (pinned[i]) continue;
      const double g = it.gradient[i];
      first += (gamma * mass[i] * velocity_[i] + (g - mass[i] * (it.x[i] - xhat[i])) / c2) * dx[i];
      decrement -= g * dx[i];
    }
    error.energy = std::abs(first) + 0.5 * std::abs(decrement) / c2;
    error.energyTolerance = input.displacement.ratio * input.energyBudget *
                            (potential_.frame().fractionEnd - potential_.frame().fractionStart);
  }
  return error;
}

std::string ImplicitIntegrator::residualText(const ForceResidual& r) const {
  if (r.dof < 0) return "no free vertex";
  std::ostringstream msg;
  msg << "largest unbalanced force " << r.largest << " N; vertex " << r.dof / model_->dim()
      << " is left with " << r.force << " N, " << 100.0 * r.relative << " % of its force scale "
      << r.scale << " N";
  return msg.str();
}

StepReport ImplicitIntegrator::step(const StepInput& input, State& state, double dt,
                                    int minSubsteps, VectorX& pinForce) {
  StepReport report;
  const int substeps = std::max(minSubsteps, 1);
  report.substeps = substeps;
  const double h = dt / substeps;
  const std::uint64_t checksBefore = input.contact ? input.contact->checks() : 0;
  for (int s = 0; s < substeps; ++s) {
    const double from = static_cast<double>(s) / substeps, to = static_cast<double>(s + 1) / substeps;
    // BDF2 assumes a smooth history. At an impact (more contacts than after the last substep) its
    // velocity (3x' - 4x + x_) / 2h still carries the approach: a cloth stopped by a floor would
    // leave it at about its impact speed, and a layer falling onto one already resting gains
    // energy (after a velocity jump in its history, BDF2 adds 7/9 of the kinetic energy the jump
    // left, however small the step). So an impact substep is redone as backward Euler, and so
    // are the two after it, whose histories (x_, v_) still hold the impact (State::impact).
    state.beginSubstep();
    const bool watchImpact = scheme_ == ImplicitScheme::Bdf2 && input.contact != nullptr;
    const bool bdf2Substep = watchImpact && state.hasHistoryFor(h);
    const StepReport before = report;
    bool ok = substep(input, state, h, substeps - s, from, to, pinForce, report);
    if (ok && watchImpact && report.contacts > state.contacts) {
      if (bdf2Substep) {
        // Again from the start of the substep, which the history holds (backward Euler reads
        // x and v alone, and the commit puts x back into xPrevious).
        state.x.swap(state.xPrevious);
        state.v.swap(state.vPrevious);
        state.historyDt = 0.0;
        report.dissipated = before.dissipated;
        report.contactWork = before.contactWork;
        report.pinWork = before.pinWork;
        report.airWork = before.airWork;
        ok = substep(input, state, h, substeps - s, from, to, pinForce, report);
      }
      if (ok) state.impact(2);
    }
    if (ok) state.contacts = report.contacts;
    if (input.contact) report.contactChecks = input.contact->checks() - checksBefore;
    if (!ok) {
      report.ok = false;  // the caller restores the state, its history with it
      return report;
    }
  }
  report.substeps = substeps;
  report.dtUsed = h;
  return report;
}

void ImplicitIntegrator::buildPotential(const StepInput& input, const State& state, double h,
                                        double fractionStart, double fractionEnd) {
  Model& model = *input.model;
  model_ = &model;
  pinned_ = input.pinned;
  contact_ = input.contact;
  air_ = input.air;
  potential_.beginSubstep(scheme_, state, h, model.dim(), model.dofMasses(), *pinned_,
                          fractionStart, fractionEnd);
  // Conservative terms: the Model's first (it owns the Hessian pattern), then the contact's,
  // then the loads; the dissipative ones after (incremental_potential.h).
  elastic_.bind(model);
  potential_.addTerm(elastic_);
  // Contact (Li et al. 2020): Phi gains c^2 (kappa B + D), whose Hessian may couple vertices
  // outside the model's pattern (self-contact), and every line search is bounded by CCD.
  if (contact_ != nullptr) {
    barrierTerm_.bind(*contact_);
    frictionTerm_.bind(*contact_);
    potential_.addTerm(barrierTerm_);  // starts the contact's substep: first
    potential_.addTerm(frictionTerm_);
  }
  loads_.setForces(*input.gravityForce, *input.externalForce);
  potential_.addTerm(loads_);
  massDamped_ = input.damping.massProportional > 0.0;
  stiffnessDamped_ = input.damping.stiffnessProportional > 0.0;
  if (massDamped_) {
    massDamping_.configure(input.damping.massProportional, model.dofMasses());
    potential_.addTerm(massDamping_);
  }
  if (stiffnessDamped_) {
    stiffnessDamping_.configure(input.damping.stiffnessProportional, model);
    potential_.addTerm(stiffnessDamping_);
  }
  if (air_ != nullptr) {
    airTerm_.bind(*air_);
    potential_.addTerm(airTerm_);
  }
}

bool ImplicitIntegrator::startingPoint(const StepInput& input, const State& state, int remaining,
                                       StepReport& report) {
  const std::vector<char>& pinned = *pinned_;
  const VectorX& mass = potential_.mass();
  const VectorX& xhat = potential_.xhat();
  const VectorX& force = loads_.force();
  const double c2 = potential_.c2();
  const Index n = model_->numDofs();
  VectorX& x = iterate_.x;
  // Candidates, pins at their targets: the explicit prediction xhat + c^2 M^-1 f, the inertial
  // prediction xhat and the current positions. The one with the lowest Phi starts Newton: the
  // explicit prediction is exact for a free fall, but under a load large against the masses it
  // lands far away (4 N on 4e-5 kg puts a vertex 10 m away in 0.01 s), and Newton started there
  // can end in a folded state that balances the forces as well. With contact, the inertial
  // prediction as far as it is safe (ContactModel::startingPoint): adding the forces would push
  // resting cloth into its supports, and Newton would then spend iterations climbing back out of
  // the barrier (each one only doubles a distance that is too small).
  x.resize(n);
  for (Index i = 0; i < n; ++i) {
    x[i] = pinned[i] ? pinAfterSubstep(state.x[i], (*input.pinTarget)[i], remaining)
                     : xhat[i] + c2 * force[i] / mass[i];
  }
  if (contact_ != nullptr) {
    xTrial_ = x;
    for (Index i = 0; i < n; ++i) {
      if (!pinned[i]) xTrial_[i] = xhat[i];
    }
    if (Status s = contact_->startingPoint(state.x, xTrial_, x); !s) {
      report.error = name() + ": " + s.error();
      return false;
    }
  }
  TermsEvaluation& eval = iterate_.terms;
  eval = potential_.evaluateTerms(x, &iterate_.termGradient);
  iterate_.phi = eval.inDomain ? potential_.value(x, eval) : kInfiniteEnergy;
  bool moved = false;
  for (int candidate = 0; candidate < 2 && contact_ == nullptr; ++candidate) {
    const VectorX& from = candidate == 0 ? xhat : state.x;
    xTrial_ = x;
    for (Index i = 0; i < n; ++i) {
      if (!pinned[i]) xTrial_[i] = from[i];
    }
    if (candidate == 1 && xTrial_ == x) continue;
    const double phi = potential_.value(xTrial_, potential_.evaluateTerms(xTrial_, nullptr));
    if (phi < iterate_.phi) {
      x.swap(xTrial_);
      iterate_.phi = phi;
      moved = true;
    }
  }
  if (moved) eval = potential_.evaluateTerms(x, &iterate_.termGradient);
  if (!eval.inDomain && contact_ != nullptr) {
    // With contact: from the current positions (the pins alone may still leave the domain).
    for (Index i = 0; i < n; ++i) {
      if (!pinned[i]) x[i] = state.x[i];
    }
    potential_.prepareStep(x, VectorX::Zero(n));
    eval = potential_.evaluateTerms(x, &iterate_.termGradient);
  }
  if (!eval.inDomain) {
    std::ostringstream msg;
    if (eval.firstBadElement >= 0) {
      msg << name() << ": the pin motion in this step pushes element " << eval.firstBadElement
          << " outside its material's domain (J <= 0)";
    } else {
      msg << name() << ": the pin motion in this step pushes the cloth into contact";
    }
    report.error = msg.str();
    return false;
  }
  iterate_.phi = potential_.value(x, eval);
  potential_.gradient(x, iterate_.termGradient, iterate_.gradient);
  return true;
}

bool ImplicitIntegrator::solve(const StepInput& input, const State& state, double h,
                               StepReport& report) {
  // Converged when the correction Newton would still make is within the acceptance's bound in
  // displacement (acceptance.h, test (a)): a fraction of the step's own truncation error at every
  // free vertex, capped by its motion in the step.
  if (sizeScale_ <= 0.0) sizeScale_ = std::max(restBoundingBoxDiagonal(model_->mesh()), 1e-12);
  NewtonProblem problem;
  problem.potential = &potential_;
  problem.hessian = &model_->hessianPattern();
  problem.pinned = pinned_;
  problem.stepTolerance = newton_.settings().tolerance * sizeScale_ * h;  // m
  // One pointer captured: std::function keeps it without a heap allocation.
  struct Context {
    ImplicitIntegrator* self;
    const StepInput* input;
    const State* state;
    double h;
  } context{this, &input, &state, h};
  problem.error = [c = &context](const NewtonIterate& it, const VectorX& dx) {
    return c->self->displacementError(*c->input, *c->state, c->h, it, dx);
  };
  bool check = false;
  if (solverKind_ == ImplicitSolver::Lbfgs) {
    // L-BFGS's own estimate of its error (its next step, on B0 = the rest stiffness wherever its
    // pairs have not measured the Hessian) understates it where the cloth is softer than at rest
    // (out of plane, bending): so its solution is accepted only when the Newton correction there,
    // by the projected Hessian at that point, is within the tolerance too. One assembly and
    // factorisation per substep; if the check fails, Newton goes on with that factorisation.
    check = quasiNewton(input, problem, report);
    if (!check && !report.error.empty()) return false;
    if (!check) ++report.solverFallbacks;  // Newton from where L-BFGS stopped (a lower Phi than the start)
  }
  const NewtonOutcome outcome = newton_.solve(problem, iterate_, check);
  if (check && outcome.iterations > 1) ++report.solverFallbacks;  // the check refused L-BFGS's solution
  report.displacement.merge(outcome.displacement);
  report.newtonIterations += outcome.iterations;
  report.lineSearchBacktracks += outcome.backtracks;
  report.newtonTimes += outcome.times;
  if (outcome.ok) return true;
  report.error = name() + ": " + outcome.error;
  if (outcome.forces) {
    const ForceResidual left = residual(input, state, h, iterate_);
    report.unbalanced.merge(left);
    report.error += " (" + residualText(left) + ")";
  }
  // An obstacle that moves farther in a substep than the cloth can follow leaves Newton no
  // balanced state (issue 30: a ball at 100 m/s): say which obstacles moved, and how fast.
  if (contact_ != nullptr) {
    const std::string moving = contact_->movingObstaclesText();
    if (!moving.empty()) report.error += " (" + moving + ")";
  }
  return false;
}

bool ImplicitIntegrator::quasiNewton(const StepInput& input, const NewtonProblem& problem,
                                     StepReport& report) {
  // B0 = (1 + c^2 gamma alpha) M + c^2 (1 + gamma beta) L: Phi's Hessian with the stiffness,
  // damped by Rayleigh's beta K0, replaced by the rest-state matrix L (initial_hessian.h).
  const double c2 = potential_.c2(), gamma = potential_.gamma();
  const double alpha = massDamped_ ? input.damping.massProportional : 0.0;
  const double beta = stiffnessDamped_ ? input.damping.stiffnessProportional : 0.0;
  std::string error;
  InitialHessian::ContactSource source;
  if (contact_ != nullptr) {
    // The barriers' and friction's 3 x 3 blocks (PSD), weighted by c^2 as Phi weights them.
    source = [this, c2](const VectorX& x, std::vector<InitialHessian::ContactBlock>& blocks) {
      contact_->prepareVertexAccess();
      const std::vector<char>& pinned = *pinned_;
      const int d = model_->dim();
      VertexDerivatives vd;
      for (Index v = 0; v < model_->numVertices(); ++v) {
        if (pinned[d * v] || !contact_->vertexDerivatives(x, v, vd)) continue;
        if (vd.hessian.isZero(0.0)) continue;
        blocks.push_back({v, c2 * vd.hessian});
      }
    };
  }
  initialHessian_.setContact(std::move(source), lbfgs_.settings().contact);
  if (!initialHessian_.prepare(*model_, *pinned_, 1.0 + c2 * gamma * alpha, c2 * (1.0 + gamma * beta),
                               iterate_.x, &error)) {
    report.error = name() + ": " + error;
    return false;
  }
  const NewtonOutcome outcome = lbfgs_.solve(problem, initialHessian_, iterate_);
  report.quasiNewtonIterations += outcome.iterations;
  report.lineSearchBacktracks += outcome.backtracks;
  report.newtonTimes += outcome.times;
  return outcome.ok;  // its error estimate is not reported: Newton's check measures it (solve)
}

bool ImplicitIntegrator::substep(const StepInput& input, State& state, double h, int remaining,
                                 double fractionStart, double fractionEnd, VectorX& pinForce,
                                 StepReport& report) {
  buildPotential(input, state, h, fractionStart, fractionEnd);
  if (!startingPoint(input, state, remaining, report)) return false;
  if (!solve(input, state, h, report)) return false;
  const ForceResidual unbalanced = residual(input, state, h, iterate_);
  report.unbalanced.merge(unbalanced);
  report.residual = report.unbalanced.largest;
  if (contact_ != nullptr) {
    ContactStats stats;
    contact_->finishSubstep(iterate_.x, state.x, stats);
    recordContact(stats, report);
    if (!stats.crossing.empty()) return false;  // a triangle inside a round obstacle
  }
  commit(state, h, pinForce, report);
  return true;
}

void ImplicitIntegrator::commit(State& state, double h, VectorX& pinForce, StepReport& report) {
  // Velocities, pin forces (the pins supply the residual force on their DOFs: the equation of
  // motion there reads dPhi/dx / c^2 = f_pin) and their work over the substep, damping work,
  // history.
  const std::vector<char>& pinned = *pinned_;
  const VectorX& x = iterate_.x;
  const VectorX& g = iterate_.gradient;
  const double c2 = potential_.c2();
  // A backward Euler substep books the pins' kinetic energy exactly (pinWorkInSubstep); BDF2's
  // velocity is not dx / h, so its pins' work stays force times displacement.
  VectorX& vNew = vNew_;
  vNew = potential_.gamma() * (x - potential_.xc());
  const VectorX& mass = potential_.mass();
  const bool backwardEuler = !potential_.isBdf2();
  for (Index i = 0; i < x.size(); ++i) {
    pinForce[i] = pinned[i] ? g[i] / c2 : 0.0;
    if (!pinned[i]) continue;
    report.pinWork += backwardEuler ? pinWorkInSubstep(pinForce[i], x[i] - state.x[i], mass[i], state.v[i], vNew[i])
                                    : pinForce[i] * (x[i] - state.x[i]);
  }
  if (massDamped_) report.dissipated += massDamping_.dissipated(vNew, h);
  if (stiffnessDamped_) report.dissipated += stiffnessDamping_.dissipated(vNew, h);
  if (air_ != nullptr) report.airWork += airTerm_.force(vNew).dot(x - state.x);
  state.xPrevious.swap(state.x);
  state.vPrevious.swap(state.v);
  state.x = x;
  state.v.swap(vNew);  // both buffers kept: no allocation next substep
  state.historyDt = h;
}

}  // namespace fem_cloth
