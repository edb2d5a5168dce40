#include "fem_cloth/core/integrators/projective_dynamics.h"

#include <algorithm>
#include <cmath>

#include "fem_cloth/core/energy_forms.h"
#include "fem_cloth/core/scene.h"
#include "fem_cloth/core/integrators/registry.h"
#include "fem_cloth/core/integrators/step_common.h"


namespace fem_cloth {

bool ProjectiveDynamics::prepare(const StepInput& input, double h, std::string* error) {
  Model& model = *input.model;
  const Index n = model.numVertices();
  const int d = model.dim();
  if (!haveLaplacian_) {
    std::vector<Eigen::Triplet<double>> triplets;
    for (std::size_t t = 0; t < model.numTerms(); ++t) {
      EnergyTerm& term = model.term(t);
      const ProjectiveForm* form = term.projectiveForm();
      if (form == nullptr) {
        *error = "projective_dynamics minimises the ARAP membrane (material.model: arap) and "
                 "quadratic bending on cloth (dim 3); energy term '" + term.name() +
                 "' has no projective form";
        return false;
      }
      form->appendProjectiveMatrix(&triplets);
    }
    laplacian_.resize(n, n);
    laplacian_.setFromTriplets(triplets.begin(), triplets.end());
    haveLaplacian_ = true;
  }
  // Pins hold whole vertices: the free system is over vertices.
  const std::vector<char>& pinned = *input.pinned;
  pinnedVertices_.resize(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) pinnedVertices_[i] = pinned[d * i];
  if (pinnedVertices_ == factorisedFor_ && h == factorisedH_) return true;
  const std::vector<char>& pinnedVertices = pinnedVertices_;

  freeIndex_.assign(n, -1);
  freeVertices_.clear();
  for (Index i = 0; i < n; ++i) {
    if (!pinnedVertices[i]) {
      freeIndex_[i] = static_cast<Index>(freeVertices_.size());
      freeVertices_.push_back(i);
    }
  }
  std::vector<Index> pinnedIndex(n, -1);
  Index numPinned = 0;
  for (Index i = 0; i < n; ++i) {
    if (pinnedVertices[i]) pinnedIndex[i] = numPinned++;
  }
  const double inertia = (1.0 + h * input.damping.massProportional) / (h * h);
  std::vector<Eigen::Triplet<double>> ff, fp;
  for (Index j = 0; j < n; ++j) {
    for (Matrix::InnerIterator it(laplacian_, j); it; ++it) {
      const Index i = static_cast<Index>(it.row());
      if (freeIndex_[i] < 0) continue;
      if (freeIndex_[j] >= 0) {
        ff.emplace_back(freeIndex_[i], freeIndex_[j], it.value());
      } else {
        fp.emplace_back(freeIndex_[i], pinnedIndex[j], it.value());
      }
    }
  }
  const Index nf = static_cast<Index>(freeVertices_.size());
  for (Index k = 0; k < nf; ++k) {
    ff.emplace_back(k, k, model.vertexMasses()[freeVertices_[k]] * inertia);
  }
  systemFree_.resize(nf, nf);
  systemFree_.setFromTriplets(ff.begin(), ff.end());
  couplingFreePinned_.resize(nf, numPinned);
  couplingFreePinned_.setFromTriplets(fp.begin(), fp.end());
  if (!factor_.compute(systemFree_, d)) {
    *error = "projective_dynamics: the system matrix could not be factorised";
    return false;
  }
  ++factorisations_;
  factorisedFor_ = pinnedVertices_;
  factorisedH_ = h;
  rhsFree_.resize(nf, d);
  solFree_.resize(nf, d);
  pinnedPositions_.resize(numPinned, d);
  return true;
}

void ProjectiveDynamics::iterate(const StepInput& input, State& state, double h, int count) {
  Model& model = *input.model;
  const int d = model.dim();
  const Index n = model.numVertices();
  const VectorX& mass = model.dofMasses();
  const VectorX& gravity = *input.gravityForce;
  const VectorX& external = *input.externalForce;
  const double alpha = input.damping.massProportional;
  const double rho = settings_.chebyshevRho;
  const Index nf = static_cast<Index>(freeVertices_.size());
  for (int k = 0; k < count; ++k, ++iteration_) {
    // Local step: the projections, as the right-hand side sum_i w_i S_i^T p_i(x).
    rhs_.setZero(n * d);
    for (std::size_t t = 0; t < model.numTerms(); ++t) model.term(t).projectiveForm()->addProjectiveRhs(state.x, &rhs_);
    // Global step on the free vertices: A_ff x_f = b_f - A_fp x_p.
    for (Index j = 0; j < nf; ++j) {
      const Index i = freeVertices_[j];
      for (int c = 0; c < d; ++c) {
        const Index dof = d * i + c;
        rhsFree_(j, c) = rhs_[dof] + gravity[dof] + external[dof] +
                         mass[dof] * (xhat_[dof] / (h * h) + alpha * xPrev_[dof] / h);
      }
    }
    rhsFree_.noalias() -= couplingFreePinned_ * pinnedPositions_;
    factor_.solve(rhsFree_, solFree_);
    if (rho > 0.0) {
      // Chebyshev semi-iteration (Wang 2015, eq. 6): blend with the iterate before last.
      const int it = iteration_;
      omega_ = it == 0 ? 1.0 : (it == 1 ? 2.0 / (2.0 - rho * rho) : 4.0 / (4.0 - rho * rho * omega_));
    }
    for (Index j = 0; j < nf; ++j) {
      const Index i = freeVertices_[j];
      for (int c = 0; c < d; ++c) {
        const Index dof = d * i + c;
        const double next = omega_ * (solFree_(j, c) - xPrevPrev_[dof]) + xPrevPrev_[dof];
        xPrevPrev_[dof] = state.x[dof];
        state.x[dof] = next;
      }
    }
  }
}

ForceResidual ProjectiveDynamics::residual(const StepInput& input, const VectorX& x, double h,
                                           double* potential) {
  // Backward Euler's equations on the true energy:
  //   r = M (x - xhat) / h^2 + alpha M (x - x0) / h - f + dE/dx(x) = dPhi/dx,
  //   Phi = |x - xhat|_M^2 / (2 h^2) + alpha |x - x0|_M^2 / (2 h) - f.x + E(x).
  // On pinned DOFs r is the force the pins supply.
  Model& model = *input.model;
  const VectorX& mass = model.dofMasses();
  force_.setZero(x.size());
  EvalRequest request;
  request.energy = potential != nullptr;
  request.gradient = &force_;
  const EvalResult elastic = model.evaluate(x, request);
  const double alpha = input.damping.massProportional;
  double phi = elastic.inDomain ? elastic.energy : kInfiniteEnergy;
  for (Index i = 0; i < x.size(); ++i) {
    velocity_[i] = (x[i] - xPrev_[i]) / h;
    const double f = (*input.gravityForce)[i] + (*input.externalForce)[i];
    const double dx = x[i] - xhat_[i];
    force_[i] += mass[i] * (dx / (h * h) + alpha * velocity_[i]) - f;
    phi += 0.5 * mass[i] * (dx * dx / (h * h) + alpha * h * velocity_[i] * velocity_[i]) - f * x[i];
  }
  if (potential != nullptr) *potential = phi;
  return measureResidual(force_, mass, *input.externalForce, *input.pinned, vStart_, velocity_, h,
                         input.residualScale.acceleration);
}

void ProjectiveDynamics::applyInverse(const VectorX& q, VectorX& z) {
  const int d = static_cast<int>(rhsFree_.cols());
  const Index nf = static_cast<Index>(freeVertices_.size());
  for (Index j = 0; j < nf; ++j) {
    for (int c = 0; c < d; ++c) rhsFree_(j, c) = q[d * freeVertices_[j] + c];
  }
  factor_.solve(rhsFree_, solFree_);
  z.setZero(q.size());
  for (Index j = 0; j < nf; ++j) {
    for (int c = 0; c < d; ++c) z[d * freeVertices_[j] + c] = solFree_(j, c);
  }
}

DisplacementError ProjectiveDynamics::displacementError(const StepInput& input, const State& state,
                                                       double h, const VectorX& dx, double moved,
                                                       int substeps) {
  // velocity_ and force_ are those of state.x (the last residual() was at it).
  const std::vector<char>& pinned = *input.pinned;
  SubstepMotion motion;
  motion.xStart = &xPrev_;
  motion.xEnd = &state.x;
  motion.vStart = &vStart_;
  motion.vEnd = &velocity_;
  motion.h = h;
  // The truncation part of the bound is cut by kUnderstatement (the estimate's); the cap on the
  // motion and the floor stay, since near a pin they, not the estimate, decide.
  DisplacementTolerance tolerance = input.displacement;
  tolerance.ratio /= kUnderstatement;
  DisplacementError error = measureDisplacementError(dx, motion, pinned, input.model->dim(), tolerance);
  // The change of the step's energy E = 1/2 v+^T M v+ + U(x) the correction would make, as for
  // backward Euler (implicit.cpp): dE/dx = M v+ / h + dU/dx, where dU/dx = r - M (x - xhat) / h^2
  // - alpha M v+ (r = dPhi/dx, the unbalanced force), and to second order the decrement
  // 1/2 r.dx.
  if (std::isfinite(input.energyBudget)) {
    const VectorX& mass = input.model->dofMasses();
    const double alpha = input.damping.massProportional;
    double first = 0.0, decrement = 0.0;
    for (Index i = 0; i < dx.size(); ++i) {
      if (pinned[i]) continue;
      const double dUdx = force_[i] - mass[i] * ((state.x[i] - xhat_[i]) / (h * h) + alpha * velocity_[i]);
      first += (mass[i] * velocity_[i] / h + dUdx) * dx[i];
      decrement += force_[i] * dx[i];
    }
    error.energy = std::abs(first) + 0.5 * std::abs(decrement);
    error.energyTolerance = tolerance.ratio * input.energyBudget / substeps;
  }
  error.scale(remainingErrorFactor(dx.norm(), moved));
  return error;
}

void ProjectiveDynamics::direction() {
  // direction_ = -H g_, H the L-BFGS inverse on H0 = A^-1 (-A^-1 g_ with no pairs yet).
  history_.apply(g_, [this](const VectorX& q, VectorX& z) { applyInverse(q, z); }, direction_);
  direction_ = -direction_;
}

DisplacementError ProjectiveDynamics::quasiNewton(const StepInput& input, State& state, double h,
                                                  int substeps) {
  // L-BFGS on Phi with the PD system matrix A = M (1 + h alpha) / h^2 + L as the initial Hessian
  // (Liu, Bouaziz & Kavan, "Quasi-Newton Methods for Real-Time Simulation of Hyperelastic
  // Materials", 2017, section 4): the same factor serves the two-loop recursion, and where the
  // local/global iteration crawls (its rate is set by how far A is from the true Hessian, near 1
  // for stiff cloth) the curvature pairs recover the missing part. A backtracking line search
  // keeps Phi decreasing; a direction that does not descend restarts from -A^-1 g.
  //
  // Converged by acceptance test (a) in displacement (acceptance.h) with the correction still to
  // make estimated by the next direction -H g: Newton's dx = -H^-1 g with the quasi-Newton
  // inverse H, which on the pairs' span is the true Hessian's and elsewhere A^-1. Entering from
  // the local/global iterations it is -A^-1 g, the next local/global step (the projections'
  // quadratic has the true gradient at the iterate, and the global step is its minimiser),
  // times 1 / (1 - theta), theta = its length over the last local/global move, their measured
  // contraction. The L-BFGS moves are not a contraction (their next direction is longer than
  // the last move in about half the iterations on the 65 x 65 hanging cloth), so there -H g is
  // taken as it is. Both understate the error in the soft modes, where A overstates the
  // Hessian: the truncation part of the bound is cut by kUnderstatement (measured).
  const std::vector<char>& pinned = *input.pinned;
  const Index n = state.x.size();
  double phi = 0.0;
  residual(input, state.x, h, &phi);
  auto freeGradient = [&](VectorX& g) {
    g = force_;
    for (Index i = 0; i < n; ++i) {
      if (pinned[i]) g[i] = 0.0;
    }
  };
  freeGradient(g_);
  history_.clear();
  direction();
  double moved = 0.0;
  for (Index i = 0; i < n; ++i) {
    if (!pinned[i]) moved += (state.x[i] - xPrevPrev_[i]) * (state.x[i] - xPrevPrev_[i]);
  }
  DisplacementError error = displacementError(input, state, h, direction_, std::sqrt(moved), substeps);
  const int limit = iteration_ + settings_.maxIterations;
  while (!error.within() && iteration_ < limit && std::isfinite(phi)) {
    ++iteration_;
    double slope = g_.dot(direction_);
    if (!(slope < 0.0)) {
      history_.clear();  // restart: the preconditioned gradient always descends (A is SPD)
      direction();
      slope = g_.dot(direction_);
    }
    double step = 1.0, accepted = 0.0, phiTrial = kInfiniteEnergy;
    for (int b = 0; b < 30 && accepted == 0.0; ++b, step *= 0.5) {
      trial_ = state.x + step * direction_;
      residual(input, trial_, h, &phiTrial);
      if (phiTrial <= phi + 1e-4 * step * slope) accepted = step;
    }
    if (accepted == 0.0) {
      // No decrease Phi can measure: its minimum to round-off. Back to the current iterate, where
      // the correction still to make is the error (no contraction to measure at round-off).
      residual(input, state.x, h, &phi);
      error = displacementError(input, state, h, direction_, 0.0, substeps);
      break;
    }
    freeGradient(gTrial_);
    history_.add(trial_, state.x, gTrial_, g_);  // kept if it carries curvature
    state.x.swap(trial_);
    g_.swap(gTrial_);
    phi = phiTrial;
    direction();
    error = displacementError(input, state, h, direction_, 0.0, substeps);
  }
  return error;
}

StepReport ProjectiveDynamics::step(const StepInput& given, State& state, double dt,
                                    int minSubsteps, VectorX& pinForce) {
  // A copy whose commanded forces include the air's, per substep (air only).
  StepInput input = given;
  StepReport report;
  Model& model = *input.model;
  const int d = model.dim();
  const Index n = model.numVertices();
  const std::vector<char>& pinned = *input.pinned;
  const VectorX& mass = model.dofMasses();
  if (input.damping.stiffnessProportional > 0.0) {
    report.ok = false;
    report.error = "projective_dynamics supports mass-proportional damping only "
                   "(damping.stiffness must be 0)";
    return report;
  }
  const int substeps = std::max(minSubsteps, 1);
  report.substeps = substeps;
  const double h = dt / substeps;
  if (!prepare(input, h, &report.error)) {
    report.ok = false;
    return report;
  }
  const double alpha = input.damping.massProportional;
  const VectorX& target = *input.pinTarget;
  velocity_.resize(n * d);

  for (int s = 0; s < substeps; ++s) {
    xPrev_ = state.x;
    vStart_ = state.v;
    // Air (air.h): its force at the substep's starting velocity, with the commanded forces.
    if (!air_.begin(given.air, *given.externalForce, state, model.vertexMasses(), h,
                    "projective_dynamics", report)) {
      return report;
    }
    input.externalForce = air_.forces();
    xhat_ = state.x + h * state.v;
    // Pins move to their interpolated targets; free vertices start from the inertial prediction
    // xhat. The forces enter through the global step's right-hand side; adding h^2 M^-1 f here
    // would only misplace the first projections, and far off under a load large against the
    // masses (4 N on 4e-5 kg at h = 0.1 s puts a vertex 1000 m away), where the few iterations
    // of a step cannot recover: the cloth settled where the forces do not balance.
    for (Index i = 0; i < n * d; ++i) {
      state.x[i] = pinned[i] ? pinAfterSubstep(xPrev_[i], target[i], substeps - s) : xhat_[i];
    }
    Index p = 0;
    for (Index i = 0; i < n; ++i) {
      if (freeIndex_[i] < 0) {
        for (int k = 0; k < d; ++k) pinnedPositions_(p, k) = state.x[d * i + k];
        ++p;
      }
    }
    xPrevPrev_ = state.x;
    omega_ = 1.0;
    iteration_ = 0;
    // The configured local/global iterations, then quasi-Newton iterations until the error in
    // displacement is within acceptance test (a) or maxIterations more are spent: a fixed count
    // would accept a state the forces cannot hold.
    iterate(input, state, h, settings_.iterations);
    if (state.x.allFinite()) report.displacement.merge(quasiNewton(input, state, h, substeps));
    // The forces, pin forces and velocities at the final positions.
    report.unbalanced.merge(residual(input, state.x, h));
    report.iterations += iteration_;
    state.v = velocity_;
    if (!stateIsFinite(state, "projective_dynamics", report)) return report;
    addMassDampingDissipation(h, alpha, state.v, mass, report);
    for (Index i = 0; i < n * d; ++i) {
      pinForce[i] = pinned[i] ? force_[i] : 0.0;
      if (pinned[i]) report.pinWork += force_[i] * (state.x[i] - xPrev_[i]);
    }
    report.airWork += air_.work(state.x);
  }
  report.residual = report.unbalanced.largest;
  report.dtUsed = h;
  return report;
}

namespace {
/// projective_dynamics' own key (integrator.chebyshev_rho), in the scene's integrator options.
struct ChebyshevOptions {
  double rho = 0.0;
};
}  // namespace

IntegratorEntry projectiveDynamicsEntry() {
  IntegratorEntry e;
  e.name = "projective_dynamics";
  e.summary = "local/global iterations on a prefactored system (Bouaziz et al. 2014)";
  // Every energy term must have the form w/2 |A x - p(x)|^2 with a constant A (Bouaziz et al.
  // 2014, sec. 3): the ARAP membrane and quadratic bending on cloth in 3D. Its constant system
  // has no place for a barrier whose Hessian changes with the contacts (and a projection after
  // the global step would undo the convergence it is chosen for), nor for stiffness damping.
  e.supports.materials = {"arap"};
  e.supports.bendingModels = {BendingModel::Quadratic};
  e.supports.planar = false;
  e.supports.contact = ContactMethod::None;
  e.supports.stiffnessDamping = false;
  e.keys = {"iterations", "chebyshev_rho"};
  e.keys.insert(e.keys.end(), displacementErrorKeys().begin(), displacementErrorKeys().end());
  // `iterations` is shared with XPBD (Scene::iterations); chebyshev_rho is its own key, kept in
  // the scene's integrator options; the error keys are acceptance test (a)'s, as backward Euler's.
  e.read = [name = e.name](const SettingsReader& r, Scene& s) -> Status {
    FEM_CLOTH_CHECK(readDisplacementTolerance(r, s));
    FEM_CLOTH_CHECK(r.integer("iterations", s.iterations));
    return r.number("chebyshev_rho", s.integratorOptions.edit<ChebyshevOptions>(name).rho);
  };
  e.check = [name = e.name](const Scene& s) -> Status {
    FEM_CLOTH_CHECK(checkDisplacementTolerance(s));
    FEM_CLOTH_CHECK(countInRange(s.iterations, 1, 100'000, "integrator.iterations"));
    const double rho = s.integratorOptions.get<ChebyshevOptions>(name).rho;
    if (!(rho >= 0.0 && rho < 1.0)) {
      return Error{"integrator.chebyshev_rho must be in [0, 1), got " + numberText(rho)};
    }
    return Status::success();
  };
  e.make = [name = e.name](const Scene& s) -> std::unique_ptr<Integrator> {
    ProjectiveDynamicsSettings settings;
    settings.iterations = s.iterations;
    settings.chebyshevRho = s.integratorOptions.get<ChebyshevOptions>(name).rho;
    return std::make_unique<ProjectiveDynamics>(settings);
  };
  return e;
}

}  // namespace fem_cloth
