#include "fem_cloth/core/integrators/symplectic_euler.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "fem_cloth/core/air.h"
#include "fem_cloth/core/contact/projection_contact.h"
#include "fem_cloth/core/scene.h"
#include "fem_cloth/core/integrators/registry.h"
#include "fem_cloth/core/integrators/step_common.h"
#include "fem_cloth/core/solvers/projected_hessian.h"

namespace fem_cloth {

double SymplecticEuler::stableStep(Model& model, const VectorX& x, const std::vector<char>& pinned,
                                   const Damping& damping) {
  SparseHessian& H = projectedHessian(model, x);
  // Power iteration on the symmetric M^-1/2 K M^-1/2 restricted to free DOFs. The start vector
  // alternates in sign from DOF to DOF so it overlaps the highest (checkerboard) modes.
  const Index n = model.numDofs();
  invSqrtMass_ = model.dofMasses().cwiseSqrt().cwiseInverse();
  powerU_.resize(n);
  powerW_.resize(n);
  powerS_.resize(n);
  const VectorX& invSqrtMass = invSqrtMass_;
  VectorX& u = powerU_;  // the iterate (unit length)
  VectorX& w = powerW_;  // B u, B = M^-1/2 K M^-1/2 on the free DOFs
  VectorX& scratch = powerS_;
  for (Index i = 0; i < n; ++i) u[i] = pinned[i] ? 0.0 : ((i / model.dim()) % 2 ? 1.0 : -1.0) + 0.1 * std::sin(i);
  double lambdaMax = 0.0;
  for (int it = 0; it < 60; ++it) {
    const double norm = u.norm();
    if (!(norm > 0.0)) break;
    u /= norm;
    w = invSqrtMass.cwiseProduct(u);
    scratch.noalias() = H.matrix() * w;
    w = invSqrtMass.cwiseProduct(scratch);
    for (Index i = 0; i < n; ++i) {
      if (pinned[i]) w[i] = 0.0;
    }
    const double estimate = u.dot(w);  // Rayleigh quotient
    const bool settled = std::abs(estimate - lambdaMax) <= 1e-3 * estimate;
    lambdaMax = estimate;
    u = w;
    if (settled && it > 10) break;
  }
  // The iteration converges from below; a 10 % margin covers the remainder.
  const double omega = std::sqrt(std::max(lambdaMax, 0.0) * 1.1);
  if (!(omega > 0.0)) return std::numeric_limits<double>::infinity();
  const double zeta = 0.5 * damping.stiffnessProportional * omega;
  return 2.0 / omega * (std::sqrt(1.0 + zeta * zeta) - zeta);
}

int SymplecticEuler::substepsFor(double dt, int minSubsteps, StepReport& report) const {
  const double usable = settings_.cflSafety * stableStep_;
  int substeps = std::max(minSubsteps, 1);
  if (dt / substeps > usable) {
    if (!settings_.autoSubstep) {
      std::ostringstream msg;
      msg << "symplectic_euler: dt = " << dt << " s is above the stable step " << usable
          << " s of this scene (" << settings_.cflSafety << " x the CFL bound " << stableStep_
          << " s); use dt <= " << usable << " s or enable substeps";
      report.ok = false;
      report.retryable = false;
      report.error = msg.str();
      return 0;
    }
    substeps = static_cast<int>(std::ceil(dt / usable));
  }
  report.substeps = substeps;
  if (substeps > settings_.maxSubsteps) {
    std::ostringstream msg;
    msg << "symplectic_euler: dt = " << dt << " s needs " << substeps
        << " substeps (stable step " << usable << " s), more than the limit "
        << settings_.maxSubsteps << "; use an implicit integrator for this scene";
    report.ok = false;
    report.retryable = false;
    report.error = msg.str();
    return 0;
  }
  return substeps;
}

bool SymplecticEuler::substepForces(const StepInput& input, const State& state, double h,
                                    StepReport& report) {
  Model& model = *input.model;
  gradient_.setZero();
  EvalRequest request;
  request.energy = false;
  request.gradient = &gradient_;
  const EvalResult r = model.evaluate(state.x, request);
  if (!r.inDomain) {
    report.ok = false;
    report.error = "symplectic_euler: element " + std::to_string(r.firstBadElement) +
                   " left its material's domain (inverted or collapsed)";
    return false;
  }
  // Air (air.h): its force at the substep's starting velocity, explicit like the rest.
  if (!air_.begin(input.air, *input.externalForce, state, model.vertexMasses(), h,
                  "symplectic_euler", report)) {
    return false;
  }
  force_ = *input.gravityForce + *air_.forces() - gradient_;
  const double beta = input.damping.stiffnessProportional;
  if (beta > 0.0) {
    // Stiffness-proportional damping -beta K v, with K v from a directional difference of
    // the elastic gradient (one more gradient evaluation, paid only when beta > 0).
    const double vnorm = state.v.norm();
    if (vnorm > 0.0) {
      const double eps = 1e-7 * (1.0 + state.x.norm()) / vnorm;
      shifted_ = state.x + eps * state.v;
      shiftedGradient_.setZero();
      request.gradient = &shiftedGradient_;
      model.evaluate(shifted_, request);
      dampingForce_ = beta * (shiftedGradient_ - gradient_) / eps;
      force_ -= dampingForce_;
    } else {
      dampingForce_.setZero();
    }
  }
  return true;
}

void SymplecticEuler::projectContact(const StepInput& input, State& state, int s, int substeps,
                                     double h, std::uint64_t checksBefore, StepReport& report) {
  // Obstacles: project out to the contact distance with Coulomb friction, inelastically (the
  // velocity follows the corrected positions; Bridson et al. 2002, section 7).
  ProjectionContact& contact = *input.projection;
  contact.beginSubstep(static_cast<double>(s) / substeps, static_cast<double>(s + 1) / substeps);
  contact.project(state.x, positionStart_, *input.pinned);
  ContactStats stats;
  contact.finishSubstep(state.x, positionStart_, h, 1.0 + h * input.damping.massProportional, stats);
  state.v += contact.correction() / h;
  recordContact(stats, report);
  report.contactChecks = contact.checks() - checksBefore;
}

StepReport SymplecticEuler::step(const StepInput& input, State& state, double dt, int minSubsteps,
                                 VectorX& pinForce) {
  StepReport report;
  Model& model = *input.model;
  const std::vector<char>& pinned = *input.pinned;
  const VectorX& mass = model.dofMasses();
  const Index n = model.numDofs();

  if (stableStep_ <= 0.0 || boundAge_ >= static_cast<std::uint64_t>(settings_.boundUpdateInterval)) {
    stableStep_ = stableStep(model, state.x, pinned, input.damping);
    boundAge_ = 0;
  }
  ++boundAge_;
  const int substeps = substepsFor(dt, minSubsteps, report);
  if (substeps == 0) return report;

  force_.resize(n);
  gradient_.resize(n);
  velocityStart_.resize(n);
  if (input.damping.stiffnessProportional > 0.0) {
    shiftedGradient_.resize(n);
    dampingForce_.resize(n);
  }
  const double h = dt / substeps;
  const double alpha = input.damping.massProportional;
  const double beta = input.damping.stiffnessProportional;
  const VectorX& target = *input.pinTarget;
  const std::uint64_t checksBefore = input.projection != nullptr ? input.projection->checks() : 0;
  for (int s = 0; s < substeps; ++s) {
    if (!substepForces(input, state, h, report)) return report;
    velocityStart_ = state.v;
    if (input.projection != nullptr) positionStart_ = state.x;
    for (Index i = 0; i < n; ++i) {
      if (pinned[i]) {
        // Along the pin's path to its end-of-step target; the pin supplies what makes the vertex
        // follow it, m dv/h - f, and does that work along the substep's displacement (the
        // kinetic energy booked exactly: pinWorkInSubstep).
        const double xNew = pinAfterSubstep(state.x[i], target[i], substeps - s);
        state.v[i] = (xNew - state.x[i]) / h;
        report.pinWork += pinWorkInSubstep(mass[i] * (state.v[i] - velocityStart_[i]) / h - force_[i],
                                           xNew - state.x[i], mass[i], velocityStart_[i], state.v[i]);
        state.x[i] = xNew;
      } else {
        state.v[i] = (state.v[i] + h * force_[i] / mass[i]) / (1.0 + h * alpha);
        state.x[i] += h * state.v[i];
      }
    }
    if (input.projection != nullptr) projectContact(input, state, s, substeps, h, checksBefore, report);
    addMassDampingDissipation(h, alpha, state.v, mass, report);
    if (beta > 0.0) report.dissipated += h * state.v.dot(dampingForce_);
    report.airWork += air_.work(state.x);
    if (!stateIsFinite(state, "symplectic_euler", report)) return report;
    if (s + 1 == substeps) {
      for (Index i = 0; i < n; ++i) {
        pinForce[i] = pinned[i] ? mass[i] * (state.v[i] - velocityStart_[i]) / h - force_[i] : 0.0;
      }
    }
  }
  report.substeps = substeps;
  report.dtUsed = h;
  stepRatio_ = stableStep_ > 0.0 ? h / stableStep_ : 0.0;
  return report;
}

double SymplecticEuler::energyTolerance() const {
  // Undamped, symplectic Euler conserves the modified energy 1/2 (v^2 + w^2 x^2 - h w^2 x v) of
  // each mode (Hairer, Lubich & Wanner, "Geometric Numerical Integration", IX.8), so the energy
  // it measures lies between 1/(1 + s) and 1/(1 - s) times it, s = h w / 2: within a step it
  // can grow by up to 2 s / (1 - s) of what the fastest modes hold. s is h over the stable step
  // 2 / w_max (0.5 at the default cfl_safety); capped at 0.9, where the bound is 18. Measured
  // against the energy scale (weight x size, the energy held, the work) rather than the fastest
  // modes' share, this is loose: slow growth (a cloth stiffening past the stable step estimated
  // up to 20 steps earlier) passes it step by step. The simulator's bound on the energy created
  // over the run (acceptance.h, test b; docs/integrators.md) catches that growth; a rollback
  // re-estimates the stable step.
  const double s = std::min(stepRatio_, 0.9);
  return std::max(kEnergyTolerance, 2.0 * s / (1.0 - s));
}

IntegratorEntry symplecticEulerEntry() {
  IntegratorEntry e;
  e.name = "symplectic_euler";
  e.summary = "explicit; substeps itself below its CFL bound (cheap steps, many of them when stiff)";
  // Obstacles by projection after each substep; self-contact needs the implicit barrier.
  e.supports.contact = ContactMethod::Projection;
  e.supports.selfContact = false;
  e.keys = {"auto_substep", "cfl_safety"};
  // Its keys set two of SymplecticEulerSettings' fields (the others keep their defaults); the
  // struct is kept in the scene's integrator options.
  e.read = [name = e.name](const SettingsReader& r, Scene& s) -> Status {
    SymplecticEulerSettings& o = s.integratorOptions.edit<SymplecticEulerSettings>(name);
    FEM_CLOTH_CHECK(r.boolean("auto_substep", o.autoSubstep));
    return r.number("cfl_safety", o.cflSafety);
  };
  e.check = [name = e.name](const Scene& s) -> Status {
    const double safety = s.integratorOptions.get<SymplecticEulerSettings>(name).cflSafety;
    if (!(safety > 0.0 && safety <= 1.0)) {
      return Error{"integrator.cfl_safety must be in (0, 1], got " + numberText(safety)};
    }
    return Status::success();
  };
  e.make = [name = e.name](const Scene& s) -> std::unique_ptr<Integrator> {
    return std::make_unique<SymplecticEuler>(s.integratorOptions.get<SymplecticEulerSettings>(name));
  };
  return e;
}

}  // namespace fem_cloth
