// Implicit steppers by minimisation of the incremental potential (Gast, Schroeder, Stomakhin,
// Jiang & Teran, "Optimization Integrator for Large Time Steps", 2015):
//
//   x+ = argmin Phi(x),  Phi(x) = 1/2 |x - xhat|_M^2 + c^2 (E(x) - f.x)
//                                 + c^2 gamma/2 (x - xc)^T (alpha M + beta K0) (x - xc)
//   v+ = gamma (x+ - xc)
//
// Backward Euler: xhat = xn + h vn, c^2 = h^2, gamma = 1/h, xc = xn.
// BDF2 (second order): xhat = 4/3 xn - 1/3 xp + 8/9 h vn - 2/9 h vp, c^2 = 4/9 h^2,
//   gamma = 3/(2h), xc = (4 xn - xp)/3, with (xp, vp) the previous step; the first step, and any
//   step whose size differs from the previous one, falls back to backward Euler.
// E is the elastic energy, f gravity plus commanded forces (constant over the step), alpha M +
// beta K0 the Rayleigh damping with K0 the projected stiffness at the start of the step.
//
// Setting dPhi/dx = 0 gives exactly the implicit update M (x - xhat) = c^2 (f - dE/dx - D v+).
// Phi is minimised by Newton's method with per-element PSD-projected Hessians (so every Newton
// direction descends) and a backtracking (Armijo) line search on Phi, which therefore never
// increases; states outside a material's domain (Neo-Hookean J <= 0) have Phi = +inf and are
// rejected by the line search. Pinned DOFs are filtered: their rows and columns are replaced by
// the identity (scaled by their mass) with zero right-hand side, which keeps the matrix pattern,
// and so the symbolic factorisation, fixed while pins come and go.
//
// Air (air.h; only when the scene has `air`): Phi gains c^2 / gamma D(gamma (x - xc)), the air's
// dissipation potential at the step's velocity with normals and areas lagged at the start of the
// substep, convex in x, so Newton stays a minimisation.
//
// Contact (contact/contact_model.h; only when the scene has obstacles or self-collision): Phi
// gains c^2 (kappa B(x) + D(x)), the barrier and lagged friction potentials of Incremental
// Potential Contact (Li et al. 2020); each Newton step is first cut to the largest fraction that
// continuous collision detection finds collision-free, so no iterate passes through anything.
#pragma once

#include "fem_cloth/core/integrators/integrator.h"
#include "fem_cloth/core/integrators/linear_solver.h"

namespace fem_cloth {

enum class ImplicitScheme { BackwardEuler, Bdf2 };

struct NewtonSettings {
  int maxIterations = 50;
  /// Converged when the last full Newton step, as a velocity |dx|_inf / h, is below
  /// tolerance x the rest bounding-box diagonal (a velocity error in cloth sizes per second)
  /// and the forces are balanced (acceptance test (a), StepInput::residualScale).
  /// The default, 1e-3, allows 1.4e-5 m per 0.01 s step on a 1 m cloth: far below backward
  /// Euler's own truncation error (about g h^2 / 2 = 5e-4 m).
  double tolerance = 1e-3;
  int maxBacktracks = 40;
  double armijo = 1e-4;  ///< sufficient-decrease constant of the line search
  LinearSolverSettings linear;
};

class ImplicitIntegrator final : public Integrator {
 public:
  ImplicitIntegrator(ImplicitScheme scheme, NewtonSettings settings);
  std::string name() const override;
  bool needsHessian() const override { return true; }
  StepReport step(const StepInput& input, State& state, double dt, int minSubsteps,
                  VectorX& pinForce) override;
  void invalidate() override {
    solver_.reset();
    sizeScale_ = 0.0;
  }

  /// The linear solver in use (null before the first step).
  const LinearSolver* linearSolver() const { return solver_.get(); }

 private:
  /// One implicit substep of size h over the fraction [fractionStart, fractionEnd] of the step;
  /// on failure returns false with report.error set.
  bool substep(const StepInput& input, State& state, double h, int remaining,
               double fractionStart, double fractionEnd, VectorX& pinForce, StepReport& report);
  /// The scheme's coefficients and Phi's per-substep data (xhat, c^2, gamma, lagged stiffness).
  void prepare(const StepInput& input, const State& state, double h);
  /// The first Newton iterate x_ (with gElastic_ and phi_ at it); false if every candidate
  /// leaves a material's domain.
  bool startingPoint(const StepInput& input, const State& state, int remaining, StepReport& report);
  /// Newton's iterations from x_ until converged; false (report.error set) if they fail.
  bool newton(const StepInput& input, const State& state, double h, StepReport& report);
  /// Assembles the Newton system at x_ and solves it for dx_.
  bool newtonStep(StepReport& report);
  /// The backtracking line search along dx_ from x_ (at most maxStep of it); true and x_ moved
  /// if it found a decrease.
  bool lineSearch(double maxStep, StepReport& report);
  /// Elastic energy and gradient at x (+ the contact potential), into gradient.
  EvalResult evaluate(const VectorX& x, VectorX& gradient);
  /// Phi at x given the elastic energy there (damping included); +inf outside the domain.
  double potential(const VectorX& x, double elastic);
  /// dPhi/dx at x given the elastic gradient there (damping included).
  void potentialGradient(const VectorX& x, const VectorX& elasticGradient, VectorX& out);
  /// Acceptance test (a) at x_: the unbalanced forces g_ / c^2 against their scale.
  ForceResidual residual(const StepInput& input, const State& state, double h);
  /// Largest |g_i| / (m_i g c^2) over free DOFs: the merit of the round-off fallback.
  double relativeGradient(const VectorX& g) const;
  std::string residualText(const ForceResidual& r) const;

  ImplicitScheme scheme_;
  NewtonSettings settings_;
  std::unique_ptr<LinearSolver> solver_;
  // Per-substep data of Phi.
  const VectorX* mass_ = nullptr;
  double c2_ = 0.0, gamma_ = 0.0, alpha_ = 0.0, beta_ = 0.0;
  VectorX xhat_, xc_, forceTotal_;
  std::vector<double> laggedStiffness_;  // beta K0 values in the model's Hessian pattern
  double sizeScale_ = 0.0;  // rest bounding-box diagonal (m)
  // Newton's state: the iterate, Phi and the elastic energy there (last evaluation).
  VectorX x_, g_, gElastic_;
  double phi_ = 0.0;
  EvalResult eval_;
  double lastFraction_ = 1.0;  // of dx_ the last line search took
  const std::vector<char>* pinned_ = nullptr;
  ContactModel* contact_ = nullptr;
  AirModel* air_ = nullptr;  // null: no air term in Phi
  VectorX airVelocity_, airForce_;
  Model* model_ = nullptr;
  // Scratch, sized once.
  VectorX dx_, rhs_, xTrial_, gTrial_, gElasticTrial_, scratch_, unbalancedForce_, velocity_;
  // Contact: Hessian entries outside the model's pattern, and the system that includes them.
  std::vector<Eigen::Triplet<double>> outsidePattern_;
  LinearSolver::Matrix contactExtra_, contactSystem_;
  // BDF2 restarts at an impact (see step()): contacts after the last substep, backward Euler
  // substeps still to take, and the state before the current substep.
  int contactsBefore_ = 0;
  int restartSubsteps_ = 0;
  State beforeImpact_;
};

}  // namespace fem_cloth
