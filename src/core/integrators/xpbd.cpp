#include "fem_cloth/core/integrators/xpbd.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include "fem_cloth/core/contact/contact_model.h"

namespace fem_cloth {

namespace {

using Jacobian = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor,
                               EnergyTerm::kMaxConstraintsPerElement, EnergyTerm::kMaxElementDofs>;
using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0,
                            EnergyTerm::kMaxConstraintsPerElement,
                            EnergyTerm::kMaxConstraintsPerElement>;
using SmallVector =
    Eigen::Matrix<double, Eigen::Dynamic, 1, 0, EnergyTerm::kMaxConstraintsPerElement, 1>;
using DofVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, EnergyTerm::kMaxElementDofs, 1>;

}  // namespace

void Xpbd::cacheStiffness(Model& model) {
  if (stiffnessModel_ == &model && stiffness_.size() == model.numTerms()) return;
  stiffness_.assign(model.numTerms(), {});
  lambda_.assign(model.numTerms(), {});
  for (std::size_t t = 0; t < model.numTerms(); ++t) {
    const EnergyTerm& term = model.term(t);
    const int k = term.constraintsPerElement();
    stiffness_[t].resize(static_cast<std::size_t>(term.numElements()) * k * k);
    lambda_[t].resize(static_cast<std::size_t>(term.numElements()) * k);
    for (Index e = 0; e < term.numElements(); ++e) {
      term.elementConstraintStiffness(e, &stiffness_[t][static_cast<std::size_t>(e) * k * k]);
    }
  }
  stiffnessModel_ = &model;
}

StepReport Xpbd::step(const StepInput& input, State& state, double dt, int minSubsteps,
                      VectorX& pinForce) {
  StepReport report;
  Model& model = *input.model;
  const std::vector<char>& pinned = *input.pinned;
  const VectorX& mass = model.dofMasses();
  const Index n = model.numDofs();
  const int d = model.dim();
  for (std::size_t t = 0; t < model.numTerms(); ++t) {
    const EnergyTerm& term = model.term(t);
    if (!term.supportsConstraints() ||
        term.constraintsPerElement() > EnergyTerm::kMaxConstraintsPerElement ||
        term.verticesPerElement() * d > EnergyTerm::kMaxElementDofs) {
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
  const double h2 = h * h;
  const double betaH = input.damping.stiffnessProportional * h;

  // Implicit mass damping, as in backward Euler: M (1 + h alpha)(x+ - xhat) / h^2 = -dE/dx with
  // xhat = x + h (v + h f / m) / (1 + h alpha). The prediction below divides by 1 + h alpha; the
  // projection must see the masses times 1 + h alpha as well, or at rest the damping would
  // cancel part of the weight (a hanging cloth then carries g / (1 + h alpha)).
  const double dampedMass = 1.0 + h * input.damping.massProportional;
  inverseMass_.resize(n);
  for (Index i = 0; i < n; ++i) inverseMass_[i] = pinned[i] ? 0.0 : 1.0 / (mass[i] * dampedMass);
  pinForce.setZero();
  const VectorX& target = *input.pinTarget;

  ContactModel* const contact = input.contact;
  Jacobian G;
  Small K, B;
  SmallVector C, lambda, rhs, dlambda;
  DofVector w, dxElement;
  for (int s = 0; s < substeps; ++s) {
    xStart_ = state.x;
    vStart_ = state.v;
    // Predict: explicit velocity update with gravity and commanded forces; pins move to their
    // interpolated targets.
    for (Index i = 0; i < n; ++i) {
      if (pinned[i]) {
        state.x[i] += (target[i] - state.x[i]) / (substeps - s);
      } else {
        const double f = (*input.gravityForce)[i] + (*input.externalForce)[i];
        state.v[i] = (state.v[i] + h * f / mass[i]) / (1.0 + h * input.damping.massProportional);
        state.x[i] += h * state.v[i];
      }
    }
    for (auto& l : lambda_) std::fill(l.begin(), l.end(), 0.0);
    if (contact != nullptr) beginContactSubstep(*contact, s, substeps);
    const bool lastSubstep = s + 1 == substeps;
    for (int it = 0; it < settings_.iterations; ++it) {
      const bool recordPinForce = lastSubstep && it + 1 == settings_.iterations;
      for (std::size_t t = 0; t < model.numTerms(); ++t) {
        const EnergyTerm& term = model.term(t);
        const int k = term.constraintsPerElement();
        const int verts = term.verticesPerElement();
        const int m = verts * d;
        G.resize(k, m);
        C.resize(k);
        w.resize(m);
        for (Index e = 0; e < term.numElements(); ++e) {
          const Index* v = term.elementVertices(e);
          if (!term.elementConstraints(e, state.x, C.data(), G.data())) {
            report.ok = false;
            report.error = "xpbd: element " + std::to_string(e) + " of " + term.name() +
                           " left its material's domain (J <= 0)";
            return report;
          }
          for (int a = 0; a < verts; ++a) {
            for (int c = 0; c < d; ++c) w[d * a + c] = inverseMass_[d * v[a] + c];
          }
          K = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
              &stiffness_[t][static_cast<std::size_t>(e) * k * k], k, k);
          Eigen::Map<Eigen::VectorXd> lam(&lambda_[t][static_cast<std::size_t>(e) * k], k);
          // [(h^2 K + beta h I) G W G^T + I] dlambda = -h^2 K C - lambda - beta h G (x - x0):
          // XPBD's update (Macklin et al. 2016, eq. 18 and 26) multiplied through by the
          // inverse compliance K h^2, which keeps it defined when K is singular.
          Small A = h2 * K;
          if (betaH > 0.0) A.diagonal().array() += betaH;
          B = A * (G * w.asDiagonal() * G.transpose());
          B.diagonal().array() += 1.0;
          rhs = -h2 * (K * C) - lam;
          if (betaH > 0.0) {
            dxElement.resize(m);
            for (int a = 0; a < verts; ++a) {
              for (int c = 0; c < d; ++c) {
                const Index dof = d * v[a] + c;
                dxElement[d * a + c] = state.x[dof] - xStart_[dof];
              }
            }
            rhs -= betaH * (G * dxElement.head(m));
          }
          dlambda = B.partialPivLu().solve(rhs);
          lam += dlambda;
          dxElement = w.asDiagonal() * (G.transpose() * dlambda);
          for (int a = 0; a < verts; ++a) {
            for (int c = 0; c < d; ++c) state.x[d * v[a] + c] += dxElement[d * a + c];
          }
          if (recordPinForce) {
            // Elastic force on the element's vertices: G^T lambda / h^2; a pin balances it.
            dxElement = G.transpose() * lam;
            for (int a = 0; a < verts; ++a) {
              for (int c = 0; c < d; ++c) {
                const Index dof = d * v[a] + c;
                if (pinned[dof]) pinForce[dof] -= dxElement[d * a + c] / h2;
              }
            }
          }
        }
      }
      // Obstacles as hard inequality constraints, projected after each sweep.
      if (contact != nullptr) contact->projectOntoObstacles(state.x, xStart_, pinned);
    }
    report.iterations += settings_.iterations;
    if (contact != nullptr) finishContactSubstep(*contact, state.x, h, dampedMass, report);
    for (Index i = 0; i < n; ++i) state.v[i] = (state.x[i] - xStart_[i]) / h;
    if (!state.x.allFinite() || !state.v.allFinite()) {
      report.ok = false;
      report.error = "xpbd: the state became non-finite";
      return report;
    }
    if (input.damping.massProportional > 0.0) {
      report.dissipated +=
          h * input.damping.massProportional * state.v.dot(mass.cwiseProduct(state.v));
    }
  }
  // The pins also carry their own vertices' weight, commanded forces and inertia.
  for (Index i = 0; i < n; ++i) {
    if (pinned[i]) {
      pinForce[i] += mass[i] * (state.v[i] - vStart_[i]) / h - (*input.gravityForce)[i] -
                     (*input.externalForce)[i];
    }
  }
  report.substeps = substeps;
  report.dtUsed = h;
  return report;
}

// The contact work lives out of line: inlined into step() it slowed the constraint sweeps of
// scenes without contact by about 15% (fem_cloth_bench Step/xpbd), which must not pay for it.
void Xpbd::beginContactSubstep(ContactModel& contact, int substep, int substeps) {
  contact.beginProjection(static_cast<double>(substep) / substeps,
                          static_cast<double>(substep + 1) / substeps);
  contactChecksBefore_ = contact.checks();
}

void Xpbd::finishContactSubstep(ContactModel& contact, VectorX& x, double h, double dampedMass,
                                StepReport& report) {
  // Coulomb friction bounded by the substep's total normal correction (Macklin, Mueller,
  // Chentanez & Kim, "Unified Particle Physics for Real-Time Applications", 2014, section 6.1).
  ContactStats stats;
  contact.finishProjection(x, xStart_, h, dampedMass, stats);
  report.contacts = stats.contacts;
  report.minContactDistance = stats.minDistance;
  report.contactWork += stats.work;
  report.contactChecks += contact.checks() - contactChecksBefore_;
}

}  // namespace fem_cloth
