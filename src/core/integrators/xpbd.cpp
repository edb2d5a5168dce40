#include "fem_cloth/core/integrators/xpbd.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>

#include "fem_cloth/core/contact/projection_contact.h"
#include "fem_cloth/core/energy_forms.h"
#include "fem_cloth/core/scene.h"
#include "fem_cloth/core/integrators/registry.h"
#include "fem_cloth/core/integrators/step_common.h"
#include "fem_cloth/core/materials/materials.h"

namespace fem_cloth {

namespace {

using Jacobian = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor,
                               ConstraintForm::kMaxConstraintsPerElement, ConstraintForm::kMaxElementDofs>;
using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0,
                            ConstraintForm::kMaxConstraintsPerElement,
                            ConstraintForm::kMaxConstraintsPerElement>;
using SmallVector =
    Eigen::Matrix<double, Eigen::Dynamic, 1, 0, ConstraintForm::kMaxConstraintsPerElement, 1>;
using DofVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, ConstraintForm::kMaxElementDofs, 1>;

}  // namespace

void Xpbd::cacheStiffness(Model& model) {
  if (stiffnessModel_ == &model && stiffness_.size() == model.numTerms()) return;
  lambdaStep_ = 0.0;
  stiffness_.assign(model.numTerms(), {});
  applied_.assign(model.numTerms(), {});
  for (std::size_t t = 0; t < model.numTerms(); ++t) {
    const ConstraintForm& term = *model.term(t).constraintForm();
    const int k = term.constraintsPerElement();
    stiffness_[t].resize(static_cast<std::size_t>(term.numElements()) * k * k);
    applied_[t].resize(static_cast<std::size_t>(term.numElements()) * term.verticesPerElement() * model.dim());
    for (Index e = 0; e < term.numElements(); ++e) {
      term.elementConstraintStiffness(e, &stiffness_[t][static_cast<std::size_t>(e) * k * k]);
    }
  }
  stiffnessModel_ = &model;
}

StepReport Xpbd::step(const StepInput& given, State& state, double dt, int minSubsteps,
                      VectorX& pinForce) {
  // A copy whose commanded forces include the air's, per substep (air only).
  StepInput input = given;
  StepReport report;
  Model& model = *input.model;
  const std::vector<char>& pinned = *input.pinned;
  const VectorX& mass = model.dofMasses();
  const Index n = model.numDofs();
  const int d = model.dim();
  for (std::size_t t = 0; t < model.numTerms(); ++t) {
    const EnergyTerm& term = model.term(t);
    const ConstraintForm* form = term.constraintForm();
    if (form == nullptr || form->constraintsPerElement() > ConstraintForm::kMaxConstraintsPerElement ||
        form->verticesPerElement() * d > ConstraintForm::kMaxElementDofs) {
      report.ok = false;
      report.retryable = false;
      report.error = "xpbd: energy term '" + term.name() +
                     "' has no constraint form; use an implicit integrator";
      return report;
    }
  }
  cacheStiffness(model);
  const int substeps = std::max(minSubsteps, 1) * std::max(settings_.substeps, 1);
  report.substeps = substeps;
  const double h = dt / substeps;
  const double betaH = input.damping.stiffnessProportional * h;

  // Implicit mass damping, as in backward Euler: M (1 + h alpha)(x+ - xhat) / h^2 = -dE/dx with
  // xhat = x + h (v + h f / m) / (1 + h alpha). The prediction below divides by 1 + h alpha; the
  // projection must see the masses times 1 + h alpha as well, or at rest the damping would
  // cancel part of the weight (a hanging cloth then carries g / (1 + h alpha)).
  const double dampedMass = 1.0 + h * input.damping.massProportional;
  inverseMass_.resize(n);
  for (Index i = 0; i < n; ++i) inverseMass_[i] = pinned[i] ? 0.0 : 1.0 / (mass[i] * dampedMass);
  const VectorX& target = *input.pinTarget;
  xPredicted_.resize(n);
  velocity_.resize(n);
  unbalanced_.resize(n);
  pinForce.setZero();

  ProjectionContact* const contact = input.projection;
  for (int s = 0; s < substeps; ++s) {
    xStart_ = state.x;
    vStart_ = state.v;
    // Air (air.h): its force at the substep's starting velocity, with the commanded forces.
    if (!air_.begin(given.air, *given.externalForce, state, model.vertexMasses(), h,
                    "xpbd", report)) {
      return report;
    }
    input.externalForce = air_.forces();
    // Predict: explicit velocity update with gravity and commanded forces; pins move to their
    // interpolated targets.
    for (Index i = 0; i < n; ++i) {
      if (pinned[i]) {
        state.x[i] = pinAfterSubstep(state.x[i], target[i], substeps - s);
      } else {
        const double f = (*input.gravityForce)[i] + (*input.externalForce)[i];
        state.v[i] = (state.v[i] + h * f / mass[i]) / (1.0 + h * input.damping.massProportional);
        state.x[i] += h * state.v[i];
      }
    }
    xPredicted_ = state.x;
    warmStart(model, state.x, h, dampedMass);
    if (contact != nullptr) beginContactSubstep(*contact, s, substeps);
    // The configured sweeps, then more (as many again at a time) until the forces balance
    // (acceptance test (a)) or maxIterations are spent.
    int sweeps = 0;
    ForceResidual unbalanced;
    while (true) {
      const int count = sweeps == 0 ? settings_.iterations
                                    : std::min(std::max(settings_.iterations, 1), settings_.maxIterations - sweeps);
      for (int it = 0; it < count; ++it, ++sweeps) {
        if (!sweep(model, state.x, h, betaH, report)) return report;
        // Obstacles as hard inequality constraints, projected after each sweep.
        if (contact != nullptr) contact->project(state.x, xStart_, pinned);
      }
      unbalanced = residual(input, state.x, h, dampedMass, betaH);
      if (unbalanced.relative <= input.residualScale.tolerance || sweeps >= settings_.maxIterations ||
          !state.x.allFinite()) {
        break;
      }
    }
    report.iterations += sweeps;
    report.unbalanced.merge(unbalanced);
    if (contact != nullptr) {
      // Friction (Macklin et al. 2014) is a correction after the solve, like symplectic Euler's
      // contact projection: test (a) judges the solve before it, test (b) what friction does
      // (it can only remove energy). The pins' share is the elastic force of the solve: friction
      // moves the free vertices after it, and the stretch that leaves next to the pins is passed
      // on by the next substep's solve, not a force the pins feel now (taken at the corrected
      // positions, the pins of a cloth dragged over a table pulled 2.4 times mu W).
      finishContactSubstep(*contact, state.x, h, dampedMass, report);
      velocity_ = (state.x - xStart_) / h;
    }
    state.v = velocity_;
    if (!stateIsFinite(state, "xpbd", report)) return report;
    addMassDampingDissipation(h, input.damping.massProportional, state.v, mass, report);
    // The pins balance the elastic force on their vertices (from the residual's pass) and also
    // carry their own vertices' weight, commanded forces and inertia; they do work along their
    // displacement in the substep.
    for (Index i = 0; i < n; ++i) {
      if (!pinned[i]) continue;
      pinForce[i] = elasticForce_[i] + mass[i] * (state.v[i] - vStart_[i]) / h -
                    (*input.gravityForce)[i] - (*input.externalForce)[i];
      report.pinWork += pinForce[i] * (state.x[i] - xStart_[i]);
    }
    report.airWork += air_.work(state.x);
  }
  report.residual = report.unbalanced.largest;
  report.substeps = substeps;
  report.dtUsed = h;
  return report;
}

void Xpbd::warmStart(Model& model, VectorX& x, double h, double dampedMass) {
  // Each element's displacement of the last substep, W G^T lambda = h^2 W f_e (f_e its force),
  // rescaled to this substep's h and masses, starts this one: the sweeps begin where the stress
  // was and only correct its change. Started from zero, every substep must rebuild the whole
  // stress, which under a load large against the masses takes many sweeps (the sudden-load
  // strip needs 256 substeps of 10 sweeps per 0.01 s cold). Converged, the start does not
  // matter. Pinned DOFs get none (W = 0 there; a vertex may have been pinned since).
  const bool warm = lambdaStep_ > 0.0;
  const double rescale =
      warm ? (h / lambdaStep_) * (h / lambdaStep_) * (lambdaDampedMass_ / dampedMass) : 0.0;
  lambdaStep_ = h;
  lambdaDampedMass_ = dampedMass;
  const int d = model.dim();
  for (std::size_t t = 0; t < model.numTerms(); ++t) {
    const ConstraintForm& term = *model.term(t).constraintForm();
    const int m = term.verticesPerElement() * d;
    for (Index e = 0; e < term.numElements(); ++e) {
      double* applied = &applied_[t][static_cast<std::size_t>(e) * m];
      const Index* v = term.elementVertices(e);
      for (int j = 0; j < m; ++j) {
        const Index dof = d * v[j / d] + j % d;
        applied[j] = inverseMass_[dof] > 0.0 ? applied[j] * rescale : 0.0;
        x[dof] += applied[j];
      }
    }
  }
}

bool Xpbd::sweep(Model& model, VectorX& x, double h, double betaH, StepReport& report) {
  const int d = model.dim();
  const double h2 = h * h;
  Jacobian G;
  Small K, B;
  SmallVector C, rhs, lambda;
  DofVector w, dx, applied;
  for (std::size_t t = 0; t < model.numTerms(); ++t) {
    const ConstraintForm& term = *model.term(t).constraintForm();
    const int k = term.constraintsPerElement();
    const int verts = term.verticesPerElement();
    const int m = verts * d;
    G.resize(k, m);
    C.resize(k);
    w.resize(m);
    dx.resize(m);
    for (Index e = 0; e < term.numElements(); ++e) {
      const Index* v = term.elementVertices(e);
      if (!term.elementConstraints(e, x, C.data(), G.data())) {
        report.ok = false;
        report.error = "xpbd: element " + std::to_string(e) + " of " + model.term(t).name() +
                       " left its material's domain (J <= 0)";
        return false;
      }
      for (int a = 0; a < verts; ++a) {
        for (int c = 0; c < d; ++c) w[d * a + c] = inverseMass_[d * v[a] + c];
      }
      K = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
          &stiffness_[t][static_cast<std::size_t>(e) * k * k], k, k);
      Eigen::Map<Eigen::VectorXd> previous(&applied_[t][static_cast<std::size_t>(e) * m], m);
      // XPBD's update (Macklin et al. 2016, eqs. 18 and 26), multiplied through by the inverse
      // compliance K h^2, which keeps it defined when K is singular, and written for the
      // element's whole multiplier lambda rather than its increment:
      //   [A G W G^T + I] lambda = -h^2 K C + A G d - beta h G (x - x0),   A = h^2 K + beta h I,
      // with d the displacement the element has given its vertices so far in this substep; the
      // element then moves them by W G^T lambda - d. Where G has not changed since d was applied
      // (d = W G^T lambda_old), this is XPBD's increment of lambda exactly. Where it has, XPBD
      // proper keeps d along the gradient of the time (the geometric stiffness dropped, eq. 11),
      // which moves its fixed point off backward Euler's by (G_old - G)^T lambda / h^2, large
      // where the stress is large against the masses (27 % of the force scale of a vertex by the
      // clamp of the sudden-load strip at h = 4e-5 s); here d is re-applied along the current G,
      // so converged XPBD solves backward Euler's equations. d, not lambda, is what is kept:
      // the singular-value constraints of corotational, ARAP and Neo-Hookean swap rows where
      // the stretches cross, which a kept lambda would follow wrongly.
      Small A = h2 * K;
      if (betaH > 0.0) A.diagonal().array() += betaH;
      B = A * (G * w.asDiagonal() * G.transpose());
      B.diagonal().array() += 1.0;
      rhs = -h2 * (K * C) + A * (G * previous);
      if (betaH > 0.0) {
        for (int a = 0; a < verts; ++a) {
          for (int c = 0; c < d; ++c) {
            const Index dof = d * v[a] + c;
            dx[d * a + c] = x[dof] - xStart_[dof];
          }
        }
        rhs -= betaH * (G * dx);
      }
      lambda = B.partialPivLu().solve(rhs);
      applied = w.asDiagonal() * (G.transpose() * lambda);
      dx = applied - previous;
      previous = applied;
      for (int a = 0; a < verts; ++a) {
        for (int c = 0; c < d; ++c) x[d * v[a] + c] += dx[d * a + c];
      }
    }
  }
  return true;
}

ForceResidual Xpbd::residual(const StepInput& input, const VectorX& x, double h, double dampedMass,
                             double betaH) {
  // XPBD's equations at convergence (Macklin et al. 2016, eqs. 8-9 with 26, multiplied out):
  //   M (1 + h alpha)(x - xpred) / h^2 + sum_e G_e^T (K_e C_e + beta / h G_e (x - x0)) = f_c,
  // backward Euler's for the constraint potential 1/2 C^T K C with XPBD's damping, here with the
  // constraint gradients at the end of the substep rather than frozen during the sweeps; f_c is
  // the obstacles' push (below).
  Model& model = *input.model;
  const int d = model.dim();
  const VectorX& mass = model.dofMasses();
  elasticForce_.setZero(x.size());
  Jacobian G;
  Small K;
  SmallVector C, f;
  DofVector dxElement;
  for (std::size_t t = 0; t < model.numTerms(); ++t) {
    const ConstraintForm& term = *model.term(t).constraintForm();
    const int k = term.constraintsPerElement();
    const int verts = term.verticesPerElement();
    G.resize(k, verts * d);
    C.resize(k);
    dxElement.resize(verts * d);
    for (Index e = 0; e < term.numElements(); ++e) {
      const Index* vertex = term.elementVertices(e);
      if (!term.elementConstraints(e, x, C.data(), G.data())) {
        // Outside the domain: not an equilibrium (the sweeps stop such states earlier).
        ForceResidual bad;
        bad.relative = bad.force = bad.largest = std::numeric_limits<double>::infinity();
        bad.dof = d * vertex[0];
        return bad;
      }
      K = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
          &stiffness_[t][static_cast<std::size_t>(e) * k * k], k, k);
      f = K * C;
      if (betaH > 0.0) {
        for (int a = 0; a < verts; ++a) {
          for (int c = 0; c < d; ++c) dxElement[d * a + c] = x[d * vertex[a] + c] - xStart_[d * vertex[a] + c];
        }
        f += betaH / (h * h) * (G * dxElement);
      }
      dxElement = G.transpose() * f;
      for (int a = 0; a < verts; ++a) {
        for (int c = 0; c < d; ++c) elasticForce_[d * vertex[a] + c] += dxElement[d * a + c];
      }
    }
  }
  // Contact projection and friction moved vertices by `correction`: the impulse of the obstacles,
  // an external force M (1 + h alpha) correction / h^2 on them.
  const VectorX* correction = input.projection != nullptr ? &input.projection->correction() : nullptr;
  for (Index i = 0; i < x.size(); ++i) {
    const double moved = x[i] - xPredicted_[i] - (correction != nullptr ? (*correction)[i] : 0.0);
    unbalanced_[i] = elasticForce_[i] + mass[i] * dampedMass * moved / (h * h);
    velocity_[i] = (x[i] - xStart_[i]) / h;
  }
  return measureResidual(unbalanced_, mass, *input.externalForce, *input.pinned, vStart_, velocity_, h,
                         input.residualScale.acceleration);
}

// The contact work lives out of line: inlined into step() it slowed the constraint sweeps of
// scenes without contact by about 15% (fem_cloth_bench Step/xpbd), which must not pay for it.
void Xpbd::beginContactSubstep(ProjectionContact& contact, int substep, int substeps) {
  contact.beginSubstep(static_cast<double>(substep) / substeps,
                          static_cast<double>(substep + 1) / substeps);
  contactChecksBefore_ = contact.checks();
}

void Xpbd::finishContactSubstep(ProjectionContact& contact, VectorX& x, double h, double dampedMass,
                                StepReport& report) {
  // Coulomb friction bounded by the substep's total normal correction (Macklin, Mueller,
  // Chentanez & Kim, "Unified Particle Physics for Real-Time Applications", 2014, section 6.1).
  ContactStats stats;
  contact.finishSubstep(x, xStart_, h, dampedMass, stats);
  recordContact(stats, report);
  report.contactChecks += contact.checks() - contactChecksBefore_;
}

IntegratorEntry xpbdEntry() {
  IntegratorEntry e;
  e.name = "xpbd";
  e.summary = "extended position-based dynamics on the FEM energy (Gauss-Seidel over elements)";
  // XPBD visits elements as constraints of at most 3 values on 4 vertices; a mid-edge bending
  // element reads 12 vertices and has no constraint form.
  e.supports.bendingModels = {BendingModel::Quadratic, BendingModel::Dihedral};
  // The materials with a constraint form (optional for a material; empty when all have one).
  e.supports.materials = materialsWithConstraintForm();
  if (e.supports.materials.size() == materialNames().size()) e.supports.materials.clear();
  e.supports.contact = ContactMethod::Projection;  // after every sweep
  e.supports.selfContact = false;
  e.keys = {"iterations"};
  e.read = [](const SettingsReader& r, Scene& s) { return r.integer("iterations", s.iterations); };
  e.check = [](const Scene& s) { return countInRange(s.iterations, 1, 100'000, "integrator.iterations"); };
  e.make = [](const Scene& s) -> std::unique_ptr<Integrator> {
    XpbdSettings settings;
    settings.iterations = s.iterations;
    return std::make_unique<Xpbd>(settings);
  };
  return e;
}

}  // namespace fem_cloth
