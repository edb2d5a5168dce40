#include "fem_cloth/core/integrators/implicit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "fem_cloth/core/air.h"
#include "fem_cloth/core/contact/contact_model.h"

namespace fem_cloth {

namespace {

using Matrix = LinearSolver::Matrix;

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

// y = K x for the values of the model's pattern given separately (y is sized here: callers pass
// scratch vectors).
void patternProduct(const Matrix& pattern, const std::vector<double>& values, const VectorX& x,
                    VectorX& y) {
  y.setZero(pattern.rows());
  const int* outer = pattern.outerIndexPtr();
  const int* inner = pattern.innerIndexPtr();
  for (Eigen::Index j = 0; j < pattern.outerSize(); ++j) {
    const double xj = x[j];
    for (int k = outer[j]; k < outer[j + 1]; ++k) y[inner[k]] += values[k] * xj;
  }
}

}  // namespace

ImplicitIntegrator::ImplicitIntegrator(ImplicitScheme scheme, NewtonSettings settings)
    : scheme_(scheme), settings_(settings) {}

std::string ImplicitIntegrator::name() const {
  return scheme_ == ImplicitScheme::BackwardEuler ? "backward_euler" : "bdf2";
}

double ImplicitIntegrator::potential(const VectorX& x, double elastic) {
  if (!std::isfinite(elastic)) return kInfiniteEnergy;
  const VectorX& m = *mass_;
  double inertia = 0.0, damping = 0.0;
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    const double d = x[i] - xhat_[i];
    inertia += m[i] * d * d;
  }
  if (alpha_ > 0.0) {
    for (Eigen::Index i = 0; i < x.size(); ++i) {
      const double d = x[i] - xc_[i];
      damping += alpha_ * m[i] * d * d;
    }
  }
  double phi = 0.5 * inertia + c2_ * (elastic - forceTotal_.dot(x)) + 0.5 * c2_ * gamma_ * damping;
  // Lagged stiffness damping beta K0, a quadratic in x - xc.
  if (beta_ > 0.0) {
    patternProduct(model_->hessianPattern().matrix(), laggedStiffness_, x - xc_, scratch_);
    phi += 0.5 * c2_ * gamma_ * (x - xc_).dot(scratch_);
  }
  // The air's dissipation potential D at v = gamma (x - xc), as c^2 / gamma D (backward Euler:
  // h^2 (h D)), whose x-gradient is -c^2 times the air force (air.h).
  if (air_ != nullptr) {
    airVelocity_ = gamma_ * (x - xc_);
    phi += c2_ / gamma_ * air_->dissipation(airVelocity_);
  }
  return phi;
}

void ImplicitIntegrator::potentialGradient(const VectorX& x, const VectorX& elasticGradient,
                                           VectorX& out) {
  const VectorX& m = *mass_;
  out = m.cwiseProduct(x - xhat_) + c2_ * (elasticGradient - forceTotal_);
  if (alpha_ > 0.0) out += (c2_ * gamma_ * alpha_) * m.cwiseProduct(x - xc_);
  if (beta_ > 0.0) {
    patternProduct(model_->hessianPattern().matrix(), laggedStiffness_, x - xc_, scratch_);
    out += c2_ * gamma_ * scratch_;
  }
  if (air_ != nullptr) {
    airVelocity_ = gamma_ * (x - xc_);
    air_->force(airVelocity_, airForce_);
    out -= c2_ * airForce_;
  }
}

EvalResult ImplicitIntegrator::evaluate(const VectorX& x, VectorX& gradient) {
  gradient.setZero(x.size());
  EvalRequest request;
  request.gradient = &gradient;
  EvalResult result = model_->evaluate(x, request);
  // The contact potential: a zero contact distance, like an element outside its domain, makes
  // the energy +inf.
  if (contact_ != nullptr && result.inDomain) {
    const double e = contact_->evaluate(x, &gradient, nullptr, nullptr, 1.0);
    result.energy += e;
    if (!std::isfinite(e)) result.inDomain = false;
  }
  return result;
}

double ImplicitIntegrator::relativeGradient(const VectorX& g) const {
  double worst = 0.0;
  for (Index i = 0; i < g.size(); ++i) {
    if (!(*pinned_)[i]) worst = std::max(worst, std::abs(g[i]) / ((*mass_)[i] * kStandardGravity));
  }
  return worst / c2_;
}

ForceResidual ImplicitIntegrator::residual(const StepInput& input, const State& state, double h) {
  // The equations of motion hold where dPhi/dx = 0; dPhi/dx / c^2 is the unbalanced force (N).
  unbalancedForce_ = g_ / c2_;
  velocity_ = gamma_ * (x_ - xc_);
  return measureResidual(unbalancedForce_, *mass_, *input.externalForce, *pinned_, state.v, velocity_, h,
                         input.residualScale.acceleration);
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
  // A failed step is rolled back by the caller: so is the impact bookkeeping.
  const int contactsAtStart = contactsBefore_, restartsAtStart = restartSubsteps_;
  for (int s = 0; s < substeps; ++s) {
    const double from = static_cast<double>(s) / substeps, to = static_cast<double>(s + 1) / substeps;
    // BDF2 assumes a smooth history. At an impact (more contacts than after the last substep) its
    // velocity (3x' - 4x + x_) / 2h still carries the approach: a cloth stopped by a floor would
    // leave it at about its impact speed, and a layer falling onto one already resting gains
    // energy (after a velocity jump in its history, BDF2 adds 7/9 of the kinetic energy the jump
    // left, however small the step). So an impact substep is redone as backward Euler, and so
    // are the two after it, whose histories (x_, v_) still hold the impact.
    if (state.xPrevious.size() != state.x.size()) contactsBefore_ = restartSubsteps_ = 0;  // new run
    if (restartSubsteps_ > 0) {
      state.historyDt = 0.0;  // backward Euler
      --restartSubsteps_;
    }
    const bool watchImpact = scheme_ == ImplicitScheme::Bdf2 && input.contact != nullptr;
    const bool bdf2Substep =
        watchImpact && state.hasHistory() && std::abs(state.historyDt - h) <= 1e-12 * h;
    double dissipatedBefore = 0.0, contactWorkBefore = 0.0, pinWorkBefore = 0.0, airWorkBefore = 0.0;
    if (bdf2Substep) {
      beforeImpact_ = state;
      dissipatedBefore = report.dissipated;
      contactWorkBefore = report.contactWork;
      pinWorkBefore = report.pinWork;
      airWorkBefore = report.airWork;
    }
    bool ok = substep(input, state, h, substeps - s, from, to, pinForce, report);
    if (ok && watchImpact && report.contacts > contactsBefore_) {
      if (bdf2Substep) {
        state = beforeImpact_;
        state.historyDt = 0.0;
        report.dissipated = dissipatedBefore;
        report.contactWork = contactWorkBefore;
        report.pinWork = pinWorkBefore;
        report.airWork = airWorkBefore;
        ok = substep(input, state, h, substeps - s, from, to, pinForce, report);
      }
      if (ok) restartSubsteps_ = 2;
    }
    if (ok) contactsBefore_ = report.contacts;
    if (input.contact) report.contactChecks = input.contact->checks() - checksBefore;
    if (!ok) {
      contactsBefore_ = contactsAtStart;
      restartSubsteps_ = restartsAtStart;
      report.ok = false;
      return report;
    }
  }
  report.substeps = substeps;
  report.dtUsed = h;
  return report;
}

void ImplicitIntegrator::prepare(const StepInput& input, const State& state, double h) {
  Model& model = *input.model;
  model_ = &model;
  pinned_ = input.pinned;
  contact_ = input.contact;
  mass_ = &model.dofMasses();
  alpha_ = input.damping.massProportional;
  beta_ = input.damping.stiffnessProportional;
  air_ = input.air;
  if (air_ != nullptr) air_->lag(state.x);  // normals and areas at the start of the substep
  const bool bdf2 = scheme_ == ImplicitScheme::Bdf2 && state.hasHistory() &&
                    std::abs(state.historyDt - h) <= 1e-12 * h;
  if (bdf2) {
    xhat_ = (4.0 / 3.0) * state.x - (1.0 / 3.0) * state.xPrevious +
            (8.0 / 9.0) * h * state.v - (2.0 / 9.0) * h * state.vPrevious;
    c2_ = 4.0 / 9.0 * h * h;
    gamma_ = 1.5 / h;
    xc_ = (4.0 * state.x - state.xPrevious) / 3.0;
  } else {
    xhat_ = state.x + h * state.v;
    c2_ = h * h;
    gamma_ = 1.0 / h;
    xc_ = state.x;
  }
  forceTotal_ = *input.gravityForce + *input.externalForce;
  if (solver_ == nullptr) solver_ = makeLinearSolver(settings_.linear, model.numDofs());
  // Lagged stiffness damping beta K0 (K0 projected, at the start of the substep).
  if (beta_ > 0.0) {
    SparseHessian& hessian = model.hessianPattern();
    hessian.setZero();
    EvalRequest request;
    request.energy = false;
    request.hessian = &hessian;
    model.evaluate(state.x, request);
    const Matrix& A = hessian.matrix();
    laggedStiffness_.assign(A.valuePtr(), A.valuePtr() + A.nonZeros());
    for (double& v : laggedStiffness_) v *= beta_;
  }
}

bool ImplicitIntegrator::startingPoint(const StepInput& input, const State& state, int remaining,
                                       StepReport& report) {
  const std::vector<char>& pinned = *pinned_;
  const VectorX& mass = *mass_;
  const Index n = model_->numDofs();
  // Candidates, pins at their targets: the explicit prediction xhat + c^2 M^-1 f, the inertial
  // prediction xhat and the current positions. The one with the lowest Phi starts Newton: the
  // explicit prediction is exact for a free fall, but under a load large against the masses it
  // lands far away (4 N on 4e-5 kg puts a vertex 10 m away in 0.01 s), and Newton started there
  // can end in a folded state that balances the forces as well. With contact, the inertial
  // prediction as far as it is safe (ContactModel::startingPoint): adding the forces would push
  // resting cloth into its supports, and Newton would then spend iterations climbing back out of
  // the barrier (each one only doubles a distance that is too small).
  x_.resize(n);
  for (Index i = 0; i < n; ++i) {
    const double target = state.x[i] + ((*input.pinTarget)[i] - state.x[i]) / remaining;
    x_[i] = pinned[i] ? target : xhat_[i] + c2_ * forceTotal_[i] / mass[i];
  }
  if (contact_ != nullptr) {
    xTrial_ = x_;
    for (Index i = 0; i < n; ++i) {
      if (!pinned[i]) xTrial_[i] = xhat_[i];
    }
    if (Status s = contact_->startingPoint(state.x, xTrial_, x_); !s) {
      report.error = name() + ": " + s.error();
      return false;
    }
  }
  eval_ = evaluate(x_, gElastic_);
  phi_ = eval_.inDomain ? potential(x_, eval_.energy) : kInfiniteEnergy;
  bool moved = false;
  for (int candidate = 0; candidate < 2 && contact_ == nullptr; ++candidate) {
    const VectorX& from = candidate == 0 ? xhat_ : state.x;
    xTrial_ = x_;
    for (Index i = 0; i < n; ++i) {
      if (!pinned[i]) xTrial_[i] = from[i];
    }
    if (candidate == 1 && xTrial_ == x_) continue;
    const double elastic = model_->evaluate(xTrial_, EvalRequest{}).energy;
    const double phi = potential(xTrial_, elastic);
    if (phi < phi_) {
      x_.swap(xTrial_);
      phi_ = phi;
      moved = true;
    }
  }
  if (moved) eval_ = evaluate(x_, gElastic_);
  if (!eval_.inDomain && contact_ != nullptr) {
    // With contact: from the current positions (the pins alone may still leave the domain).
    for (Index i = 0; i < n; ++i) {
      if (!pinned[i]) x_[i] = state.x[i];
    }
    contact_->prepareSegment(x_, VectorX::Zero(n));
    eval_ = evaluate(x_, gElastic_);
  }
  if (!eval_.inDomain) {
    std::ostringstream msg;
    if (eval_.firstBadElement >= 0) {
      msg << name() << ": the pin motion in this step pushes element " << eval_.firstBadElement
          << " outside its material's domain (J <= 0)";
    } else {
      msg << name() << ": the pin motion in this step pushes the cloth into contact";
    }
    report.error = msg.str();
    return false;
  }
  phi_ = potential(x_, eval_.energy);
  potentialGradient(x_, gElastic_, g_);
  return true;
}

bool ImplicitIntegrator::newtonStep(StepReport& report) {
  const std::vector<char>& pinned = *pinned_;
  const VectorX& mass = *mass_;
  const Index n = model_->numDofs();
  SparseHessian& hessian = model_->hessianPattern();
  Matrix& A = hessian.matrix();
  // System matrix: M (1 + c^2 gamma alpha) + c^2 K + c^2 gamma beta K0, pins filtered.
  hessian.setZero();
  EvalRequest hessianOnly;
  hessianOnly.energy = false;
  hessianOnly.hessian = &hessian;
  hessianOnly.hessianMode = HessianMode::Projected;
  model_->evaluate(x_, hessianOnly);
  double* values = A.valuePtr();
  const Eigen::Index nnz = A.nonZeros();
  for (Eigen::Index k = 0; k < nnz; ++k) values[k] *= c2_;
  if (beta_ > 0.0) {
    for (Eigen::Index k = 0; k < nnz; ++k) values[k] += c2_ * gamma_ * laggedStiffness_[k];
  }
  for (Index i = 0; i < n; ++i) {
    values[hessian.diagonalOffset(i)] += mass[i] * (1.0 + c2_ * gamma_ * alpha_);
  }
  // The air's c^2 / gamma D(gamma (x - xc)) has the x-Hessian c^2 gamma d^2D/dv^2 (PSD).
  if (air_ != nullptr) {
    airVelocity_ = gamma_ * (x_ - xc_);
    air_->addHessian(airVelocity_, c2_ * gamma_, hessian);
  }
  // Contact Hessian (c^2 times): entries outside the model's pattern make a system of its own.
  Matrix* system = &A;
  if (contact_ != nullptr) {
    outsidePattern_.clear();
    contact_->evaluate(x_, nullptr, &hessian, &outsidePattern_, c2_);
    if (!outsidePattern_.empty()) {
      contactExtra_.resize(n, n);
      contactExtra_.setFromTriplets(outsidePattern_.begin(), outsidePattern_.end());
      contactSystem_ = A + contactExtra_;
      system = &contactSystem_;
    }
  }
  filterPinned(*system, pinned, mass);
  rhs_ = -g_;
  for (Index i = 0; i < n; ++i) {
    if (pinned[i]) rhs_[i] = 0.0;
  }
  dx_.setZero(n);
  if (!solver_->compute(*system) || !solver_->solve(rhs_, dx_)) {
    report.error = name() + ": the linear solve (" + solver_->name() + ") failed";
    return false;
  }
  return true;
}

bool ImplicitIntegrator::lineSearch(double maxStep, StepReport& report) {
  // Backtracking line search on Phi (Armijo); +inf (outside the domain) always backtracks.
  const double slope = g_.dot(dx_);
  double step = maxStep;
  // Close to the minimum the decrease a Newton step makes, about -slope/2 (Newton decrement),
  // falls below the round-off of Phi itself, which is of order eps times the magnitudes of its
  // terms. Comparing Phi values there only compares noise: the search accepts tiny random
  // steps and Newton stalls just above a tight tolerance (and more so after a rollback, since
  // the decrement scales with c^4 and Phi with c^2). There the force residual, which has no
  // such cancellation, is the merit function instead: the full step is taken if it lowers it.
  const double phiScale =
      std::abs(phi_) + 2.0 * c2_ * (std::abs(eval_.energy) + std::abs(forceTotal_.dot(x_)));
  if (-slope <= 1e3 * std::numeric_limits<double>::epsilon() * phiScale && maxStep >= 1.0) {
    xTrial_ = x_ + dx_;
    const EvalResult trial = evaluate(xTrial_, gElasticTrial_);
    if (trial.inDomain) {
      potentialGradient(xTrial_, gElasticTrial_, gTrial_);
      if (relativeGradient(gTrial_) < relativeGradient(g_)) {
        eval_ = trial;
        phi_ = potential(xTrial_, trial.energy);
        return true;
      }
    }
  }
  for (int b = 0; b <= settings_.maxBacktracks; ++b) {
    xTrial_ = x_ + step * dx_;
    const EvalResult trial = evaluate(xTrial_, gElasticTrial_);
    const double phiTrial = trial.inDomain ? potential(xTrial_, trial.energy) : kInfiniteEnergy;
    if (phiTrial <= phi_ + settings_.armijo * step * slope) {
      phi_ = phiTrial;
      eval_ = trial;
      lastFraction_ = step;
      return true;
    }
    ++report.lineSearchBacktracks;
    step *= 0.5;
  }
  return false;
}

bool ImplicitIntegrator::newton(const StepInput& input, const State& state, double h,
                                StepReport& report) {
  // Convergence needs both (a) the Newton-decrement criterion of Li et al., "Incremental
  // Potential Contact", 2020: Newton converges quadratically, so the length of the last full
  // Newton step bounds the remaining error; converged when that step, as a velocity |dx|_inf / h,
  // is below tolerance x the size of the cloth (a velocity error in cloth sizes per second,
  // meaningful with or without gravity and for any mesh resolution); and (b) balanced forces:
  // the unbalanced force on every free DOF within the acceptance bound (acceptance.h, test (a)).
  // A short step alone is not enough: its length is measured against h, and for a large h
  // (100 s) "short" allows a step of metres, while around a kink of the energy steps shorten
  // without the forces balancing.
  if (sizeScale_ <= 0.0) sizeScale_ = std::max(restBoundingBoxDiagonal(model_->mesh()), 1e-12);
  const double stepTolerance = settings_.tolerance * sizeScale_ * h;  // m
  const double tolerance = input.residualScale.tolerance;
  double lastStep = std::numeric_limits<double>::infinity();
  int iterations = 0;
  auto fail = [&](const std::string& what) {
    report.newtonIterations += iterations;
    report.unbalanced.merge(residual(input, state, h));
    report.error = name() + ": " + what + " (" + residualText(residual(input, state, h)) + ")";
    return false;
  };
  auto moveTo = [&]() {
    x_.swap(xTrial_);
    gElastic_.swap(gElasticTrial_);
    potentialGradient(x_, gElastic_, g_);
  };
  while (true) {
    if (iterations >= settings_.maxIterations) {
      std::ostringstream msg;
      msg << "Newton did not converge in " << iterations << " iterations (last step "
          << lastStep / h << " m/s, tolerance " << stepTolerance / h << " m/s)";
      return fail(msg.str());
    }
    ++iterations;
    if (!newtonStep(report)) {
      report.newtonIterations += iterations;
      return false;
    }
    const double stepLength = dx_.cwiseAbs().maxCoeff();
    lastStep = stepLength;
    // With contact the step may go only as far as CCD finds collision-free.
    const double maxStep = contact_ != nullptr ? contact_->prepareSegment(x_, dx_) : 1.0;
    if (stepLength <= stepTolerance && maxStep >= 1.0) {
      // A Newton step shorter than the tolerance: the error left is below it. Take the step (if
      // it stays in the domain), without a line search, whose test would only compare round-off;
      // stop if the forces balance.
      xTrial_ = x_ + dx_;
      const EvalResult trial = evaluate(xTrial_, gElasticTrial_);
      if (trial.inDomain) {
        eval_ = trial;
        moveTo();
        phi_ = potential(x_, eval_.energy);
      }
      if (residual(input, state, h).relative <= tolerance) break;
      continue;
    }
    lastFraction_ = 1.0;
    if (!lineSearch(maxStep, report)) {
      // No measurable decrease of Phi: at its minimum to round-off, if the forces balance.
      if (residual(input, state, h).relative <= tolerance) break;
      std::ostringstream msg;
      msg << "the line search found no decrease of the incremental potential after "
          << settings_.maxBacktracks << " backtracks";
      return fail(msg.str());
    }
    moveTo();
    // A full Newton step that was already short: converged without another solve.
    if (lastFraction_ == 1.0 && stepLength <= stepTolerance &&
        residual(input, state, h).relative <= tolerance) {
      break;
    }
  }
  report.newtonIterations += iterations;
  if (!x_.allFinite()) {
    report.error = name() + ": the Newton iterate became non-finite";
    return false;
  }
  return true;
}

bool ImplicitIntegrator::substep(const StepInput& input, State& state, double h, int remaining,
                                 double fractionStart, double fractionEnd, VectorX& pinForce,
                                 StepReport& report) {
  prepare(input, state, h);
  const std::vector<char>& pinned = *pinned_;
  const VectorX& mass = *mass_;
  const Index n = model_->numDofs();
  // Contact (Li et al. 2020): Phi gains c^2 (kappa B + D), whose Hessian may couple vertices
  // outside the model's pattern (self-contact), and every line search is bounded by CCD.
  if (contact_ != nullptr) {
    contact_->beginSubstep(state.x, xc_, gamma_, h, pinned, fractionStart, fractionEnd);
  }
  if (!startingPoint(input, state, remaining, report)) return false;
  if (!newton(input, state, h, report)) return false;
  const ForceResidual unbalanced = residual(input, state, h);
  report.unbalanced.merge(unbalanced);
  report.residual = report.unbalanced.largest;

  if (contact_ != nullptr) {
    ContactStats stats;
    contact_->finishSubstep(x_, state.x, stats);
    report.contacts = stats.contacts;
    report.minContactDistance = stats.minDistance;
    report.contactWork += stats.work;
  }

  // Commit: velocities, pin forces (the pins supply the residual force on their DOFs: the
  // equation of motion there reads dPhi/dx / c^2 = f_pin) and their work over the substep,
  // damping work, history.
  VectorX vNew = gamma_ * (x_ - xc_);
  for (Index i = 0; i < n; ++i) {
    pinForce[i] = pinned[i] ? g_[i] / c2_ : 0.0;
    if (pinned[i]) report.pinWork += pinForce[i] * (x_[i] - state.x[i]);
  }
  if (alpha_ > 0.0) report.dissipated += h * alpha_ * vNew.dot(mass.cwiseProduct(vNew));
  if (beta_ > 0.0) {
    patternProduct(model_->hessianPattern().matrix(), laggedStiffness_, vNew, scratch_);
    report.dissipated += h * vNew.dot(scratch_);
  }
  if (air_ != nullptr) {
    air_->force(vNew, airForce_);
    report.airWork += airForce_.dot(x_ - state.x);
  }
  state.xPrevious.swap(state.x);
  state.vPrevious.swap(state.v);
  state.x = x_;
  state.v = std::move(vNew);
  state.historyDt = h;
  return true;
}

}  // namespace fem_cloth
