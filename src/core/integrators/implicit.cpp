#include "fem_cloth/core/integrators/implicit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "fem_cloth/core/contact/contact_model.h"

namespace fem_cloth {

namespace {

using Matrix = LinearSolver::Matrix;

constexpr double kStandardGravity = 9.81;  // m/s^2, scale of the round-off fallback's merit

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

// y = K x for the values of the model's pattern given separately.
void patternProduct(const Matrix& pattern, const std::vector<double>& values, const VectorX& x,
                    VectorX& y) {
  y.setZero();
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

double ImplicitIntegrator::potential(const VectorX& x, double elastic) const {
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
  return 0.5 * inertia + c2_ * (elastic - forceTotal_.dot(x)) + 0.5 * c2_ * gamma_ * damping;
}

void ImplicitIntegrator::potentialGradient(const VectorX& x, const VectorX& elasticGradient,
                                           VectorX& out) const {
  const VectorX& m = *mass_;
  out = m.cwiseProduct(x - xhat_) + c2_ * (elasticGradient - forceTotal_);
  if (alpha_ > 0.0) out += (c2_ * gamma_ * alpha_) * m.cwiseProduct(x - xc_);
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
    // BDF2 assumes a smooth history. At an impact (contacts where the last substep had none) its
    // velocity (3x' - 4x + x_) / 2h still carries the approach: a cloth stopped by a floor would
    // leave it at about its impact speed. So an impact substep is redone as backward Euler, and
    // so are the two after it, whose histories (x_, v_) still hold the impact.
    if (state.xPrevious.size() != state.x.size()) contactsBefore_ = restartSubsteps_ = 0;  // new run
    if (restartSubsteps_ > 0) {
      state.historyDt = 0.0;  // backward Euler
      --restartSubsteps_;
    }
    const bool watchImpact = scheme_ == ImplicitScheme::Bdf2 && input.contact != nullptr &&
                             contactsBefore_ == 0;
    const bool bdf2Substep =
        watchImpact && state.hasHistory() && std::abs(state.historyDt - h) <= 1e-12 * h;
    double dissipatedBefore = 0.0, contactWorkBefore = 0.0;
    if (bdf2Substep) {
      beforeImpact_ = state;
      dissipatedBefore = report.dissipated;
      contactWorkBefore = report.contactWork;
    }
    bool ok = substep(input, state, h, substeps - s, from, to, pinForce, report);
    if (ok && watchImpact && report.contacts > 0) {
      if (bdf2Substep) {
        state = beforeImpact_;
        state.historyDt = 0.0;
        report.dissipated = dissipatedBefore;
        report.contactWork = contactWorkBefore;
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

bool ImplicitIntegrator::substep(const StepInput& input, State& state, double h, int remaining,
                                 double fractionStart, double fractionEnd, VectorX& pinForce,
                                 StepReport& report) {
  Model& model = *input.model;
  const std::vector<char>& pinned = *input.pinned;
  const VectorX& mass = model.dofMasses();
  const Index n = model.numDofs();
  mass_ = &mass;
  alpha_ = input.damping.massProportional;
  beta_ = input.damping.stiffnessProportional;

  // Scheme coefficients.
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

  SparseHessian& hessian = model.hessianPattern();
  Matrix& A = hessian.matrix();
  if (solver_ == nullptr) solver_ = makeLinearSolver(settings_.linear, n);

  // Lagged stiffness damping beta K0 (K0 projected, at the start of the substep).
  if (beta_ > 0.0) {
    hessian.setZero();
    EvalRequest request;
    request.energy = false;
    request.hessian = &hessian;
    model.evaluate(state.x, request);
    laggedStiffness_.assign(A.valuePtr(), A.valuePtr() + A.nonZeros());
    for (double& v : laggedStiffness_) v *= beta_;
  }
  auto dampingGradient = [&](const VectorX& x, VectorX& g) {
    if (beta_ <= 0.0) return;
    patternProduct(A, laggedStiffness_, x - xc_, scratch_);
    g += c2_ * gamma_ * scratch_;
  };
  auto dampingEnergy = [&](const VectorX& x) {
    if (beta_ <= 0.0) return 0.0;
    patternProduct(A, laggedStiffness_, x - xc_, scratch_);
    return 0.5 * c2_ * gamma_ * (x - xc_).dot(scratch_);
  };

  // Contact (Li et al. 2020): Phi gains c^2 (kappa B + D), whose Hessian may couple vertices
  // outside the model's pattern (self-contact), and every line search is bounded by CCD.
  ContactModel* const contact = input.contact;
  if (contact != nullptr) {
    contact->beginSubstep(state.x, xc_, gamma_, h, pinned, fractionStart, fractionEnd);
  }
  // Elastic energy and gradient, plus the contact potential; a zero contact distance, like an
  // element outside its domain, makes the energy +inf.
  EvalRequest energyAndGradient;
  auto evaluate = [&](const VectorX& x, VectorX& gradient) {
    gradient.setZero(n);
    energyAndGradient.gradient = &gradient;
    EvalResult result = model.evaluate(x, energyAndGradient);
    if (contact != nullptr && result.inDomain) {
      const double e = contact->evaluate(x, &gradient, nullptr, nullptr, 1.0);
      result.energy += e;
      if (!std::isfinite(e)) result.inDomain = false;
    }
    return result;
  };

  // Initial guess: the explicit prediction xhat + c^2 M^-1 f, pins at their targets. With
  // contact, the inertial prediction xhat instead, as far as it is safe (startingPoint): adding
  // the forces would push resting cloth into its supports, and Newton would then spend
  // iterations climbing back out of the barrier (each one only doubles a distance that is too
  // small). If the guess leaves a material's domain, start from the current positions instead.
  x_.resize(n);
  for (Index i = 0; i < n; ++i) {
    const double target = state.x[i] + ((*input.pinTarget)[i] - state.x[i]) / remaining;
    x_[i] = pinned[i] ? target : xhat_[i] + c2_ * forceTotal_[i] / mass[i];
  }
  if (contact != nullptr) {
    xTrial_ = x_;
    for (Index i = 0; i < n; ++i) {
      if (!pinned[i]) xTrial_[i] = xhat_[i];
    }
    if (Status s = contact->startingPoint(state.x, xTrial_, x_); !s) {
      report.error = name() + ": " + s.error();
      return false;
    }
  }
  EvalResult r = evaluate(x_, gElastic_);
  if (!r.inDomain) {
    for (Index i = 0; i < n; ++i) {
      if (!pinned[i]) x_[i] = state.x[i];
    }
    if (contact != nullptr) contact->prepareSegment(x_, VectorX::Zero(n));
    r = evaluate(x_, gElastic_);
    if (!r.inDomain) {
      std::ostringstream msg;
      if (r.firstBadElement >= 0) {
        msg << name() << ": the pin motion in this step pushes element " << r.firstBadElement
            << " outside its material's domain (J <= 0)";
      } else {
        msg << name() << ": the pin motion in this step pushes the cloth into contact";
      }
      report.error = msg.str();
      return false;
    }
  }
  double phi = potential(x_, r.energy) + dampingEnergy(x_);
  potentialGradient(x_, gElastic_, g_);
  dampingGradient(x_, g_);

  // Convergence (the Newton decrement criterion of Li et al., "Incremental Potential Contact",
  // 2020): Newton converges quadratically, so the length of the last full Newton step bounds the
  // remaining error. Converged when that step, as a velocity |dx|_inf / h, is below tolerance x
  // the size of the cloth (the rest bounding-box diagonal): a velocity error measured in cloth
  // sizes per second, meaningful with or without gravity and for any mesh resolution.
  // The unbalanced forces relative to each vertex's weight remain the merit function of the
  // round-off fallback below; the reported residual is the largest unbalanced force (N).
  auto relativeResidualOf = [&](const VectorX& g) {
    double worst = 0.0;
    for (Index i = 0; i < n; ++i) {
      if (!pinned[i]) worst = std::max(worst, std::abs(g[i]) / (mass[i] * kStandardGravity));
    }
    return worst / c2_;
  };
  auto residualOf = [&](const VectorX& g) {
    double worst = 0.0;
    for (Index i = 0; i < n; ++i) {
      if (!pinned[i]) worst = std::max(worst, std::abs(g[i]));
    }
    return worst / c2_;
  };
  if (sizeScale_ <= 0.0) sizeScale_ = std::max(restBoundingBoxDiagonal(model.mesh()), 1e-12);
  const double stepTolerance = settings_.tolerance * sizeScale_ * h;  // m
  double relative = relativeResidualOf(g_);
  double lastStep = std::numeric_limits<double>::infinity();
  int iterations = 0;
  EvalRequest hessianOnly;
  hessianOnly.energy = false;
  hessianOnly.hessian = &hessian;
  hessianOnly.hessianMode = HessianMode::Projected;
  while (true) {
    if (iterations >= settings_.maxIterations) {
      std::ostringstream msg;
      msg << name() << ": Newton did not converge in " << iterations << " iterations (last step "
          << lastStep / h << " m/s, tolerance " << stepTolerance / h
          << " m/s; largest unbalanced force " << residualOf(g_) << " N)";
      report.error = msg.str();
      report.newtonIterations += iterations;
      report.residual = residualOf(g_);
      return false;
    }
    ++iterations;
    // System matrix: M (1 + c^2 gamma alpha) + c^2 K + c^2 gamma beta K0, pins filtered.
    hessian.setZero();
    model.evaluate(x_, hessianOnly);
    double* values = A.valuePtr();
    const Eigen::Index nnz = A.nonZeros();
    for (Eigen::Index k = 0; k < nnz; ++k) values[k] *= c2_;
    if (beta_ > 0.0) {
      for (Eigen::Index k = 0; k < nnz; ++k) values[k] += c2_ * gamma_ * laggedStiffness_[k];
    }
    for (Index i = 0; i < n; ++i) {
      values[hessian.diagonalOffset(i)] += mass[i] * (1.0 + c2_ * gamma_ * alpha_);
    }
    // Contact Hessian (c^2 times): entries outside the model's pattern make a system of its own.
    Matrix* system = &A;
    if (contact != nullptr) {
      outsidePattern_.clear();
      contact->evaluate(x_, nullptr, &hessian, &outsidePattern_, c2_);
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
      report.newtonIterations += iterations;
      return false;
    }
    // A Newton step shorter than the tolerance: the error left is below it. Take the step (if it
    // stays in the domain) and stop; no line search, whose test would only compare round-off.
    const double stepLength = dx_.cwiseAbs().maxCoeff();
    lastStep = stepLength;
    // With contact the step may go only as far as CCD finds collision-free.
    const double maxStep = contact != nullptr ? contact->prepareSegment(x_, dx_) : 1.0;
    if (stepLength <= stepTolerance && maxStep >= 1.0) {
      xTrial_ = x_ + dx_;
      if (evaluate(xTrial_, gElasticTrial_).inDomain) {
        x_.swap(xTrial_);
        gElastic_.swap(gElasticTrial_);
        potentialGradient(x_, gElastic_, g_);
        dampingGradient(x_, g_);
      }
      break;
    }
    // Backtracking line search on Phi (Armijo); +inf (outside the domain) always backtracks.
    const double slope = g_.dot(dx_);
    double step = maxStep;
    bool accepted = false;
    // Close to the minimum the decrease a Newton step makes, about -slope/2 (Newton decrement),
    // falls below the round-off of Phi itself, which is of order eps times the magnitudes of its
    // terms. Comparing Phi values there only compares noise: the search accepts tiny random
    // steps and Newton stalls just above a tight tolerance (and more so after a rollback, since
    // the decrement scales with c^4 and Phi with c^2). There the force residual, which has no
    // such cancellation, is the merit function instead: the full step is taken if it lowers it.
    const double phiScale =
        std::abs(phi) + 2.0 * c2_ * (std::abs(r.energy) + std::abs(forceTotal_.dot(x_)));
    if (-slope <= 1e3 * std::numeric_limits<double>::epsilon() * phiScale && maxStep >= 1.0) {
      xTrial_ = x_ + dx_;
      const EvalResult trial = evaluate(xTrial_, gElasticTrial_);
      if (trial.inDomain) {
        potentialGradient(xTrial_, gElasticTrial_, gTrial_);
        dampingGradient(xTrial_, gTrial_);
        if (relativeResidualOf(gTrial_) < relative) {
          accepted = true;
          r = trial;
          phi = potential(xTrial_, trial.energy) + dampingEnergy(xTrial_);
        }
      }
    }
    for (int b = 0; b <= settings_.maxBacktracks && !accepted; ++b) {
      xTrial_ = x_ + step * dx_;
      const EvalResult trial = evaluate(xTrial_, gElasticTrial_);
      const double phiTrial =
          trial.inDomain ? potential(xTrial_, trial.energy) + dampingEnergy(xTrial_)
                         : kInfiniteEnergy;
      if (phiTrial <= phi + settings_.armijo * step * slope) {
        accepted = true;
        phi = phiTrial;
        r = trial;
        break;
      }
      ++report.lineSearchBacktracks;
      step *= 0.5;
    }
    if (!accepted) {
      // Round-off can make the decrease unmeasurable very close to the minimum.
      if (stepLength <= 1e3 * stepTolerance) break;
      std::ostringstream msg;
      msg << name() << ": the line search found no decrease of the incremental potential after "
          << settings_.maxBacktracks << " backtracks (largest unbalanced force " << residualOf(g_)
          << " N)";
      report.error = msg.str();
      report.newtonIterations += iterations;
      report.residual = residualOf(g_);
      return false;
    }
    x_.swap(xTrial_);
    gElastic_.swap(gElasticTrial_);
    potentialGradient(x_, gElastic_, g_);
    dampingGradient(x_, g_);
    relative = relativeResidualOf(g_);
    // A full Newton step that was already short: converged without another solve.
    if (step == 1.0 && stepLength <= stepTolerance) break;
  }
  report.newtonIterations += iterations;
  report.residual = residualOf(g_);
  if (!x_.allFinite()) {
    report.error = name() + ": the Newton iterate became non-finite";
    return false;
  }

  if (contact != nullptr) {
    ContactStats stats;
    contact->finishSubstep(x_, state.x, stats);
    report.contacts = stats.contacts;
    report.minContactDistance = stats.minDistance;
    report.contactWork += stats.work;
  }

  // Commit: velocities, pin forces (the pins supply the residual force on their DOFs: the
  // equation of motion there reads dPhi/dx / c^2 = f_pin), damping work, history.
  VectorX vNew = gamma_ * (x_ - xc_);
  for (Index i = 0; i < n; ++i) pinForce[i] = pinned[i] ? g_[i] / c2_ : 0.0;
  if (alpha_ > 0.0) report.dissipated += h * alpha_ * vNew.dot(mass.cwiseProduct(vNew));
  if (beta_ > 0.0) {
    patternProduct(A, laggedStiffness_, vNew, scratch_);
    report.dissipated += h * vNew.dot(scratch_);
  }
  state.xPrevious.swap(state.x);
  state.vPrevious.swap(state.v);
  state.x = x_;
  state.v = std::move(vNew);
  state.historyDt = h;
  return true;
}

}  // namespace fem_cloth
