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
// This class is thin: each substep it builds Phi as an IncrementalPotential of terms
// (potential/incremental_potential.h, potential/terms.h), has NewtonSolver (solvers/newton.h:
// projected Newton, pins eliminated, CCD-bounded Armijo line search, so Phi never increases and
// states outside a material's domain, Phi = +inf, are rejected) minimise it from a starting
// point of its own, and books the result: velocities, pin forces, damping and air work, and the
// State's history, which also carries the BDF2 restart after an impact (see step()).
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
#include "fem_cloth/core/potential/incremental_potential.h"
#include "fem_cloth/core/potential/terms.h"
#include "fem_cloth/core/solvers/lbfgs.h"
#include "fem_cloth/core/solvers/newton.h"

namespace fem_cloth {

/// Which solver minimises Phi (`integrator.solver`): projected Newton (solvers/newton.h) or
/// L-BFGS on a prefactored rest-state matrix (solvers/lbfgs.h), whose solution of a substep is
/// accepted only when Newton's correction there (one projected Hessian) is within the tolerance,
/// and which falls back to Newton for a substep where it stalls or that check refuses
/// (StepReport::solverFallbacks counts them).
enum class ImplicitSolver { Newton, Lbfgs };

struct ImplicitSolverSettings {
  ImplicitSolver kind = ImplicitSolver::Newton;
  QuasiNewtonSettings lbfgs;
};

/// "newton" or "lbfgs"; anything else is an error naming the known values.
Expected<ImplicitSolver> parseImplicitSolver(const std::string& name);
std::string implicitSolverName(ImplicitSolver kind);

class ImplicitIntegrator final : public Integrator {
 public:
  ImplicitIntegrator(ImplicitScheme scheme, NewtonSettings settings,
                     ImplicitSolverSettings solver = {});
  std::string name() const override;
  bool needsHessian() const override { return true; }
  StepReport step(const StepInput& input, State& state, double dt, int minSubsteps,
                  VectorX& pinForce) override;
  void invalidate() override {
    newton_.invalidate();
    initialHessian_.invalidate();
    sizeScale_ = 0.0;
  }

  /// The solver that minimises Phi (integrator.solver).
  ImplicitSolver solver() const { return solverKind_; }
  /// The linear solver in use (null before the first step).
  const LinearSolver* linearSolver() const { return newton_.linearSolver(); }
  /// The quasi-Newton solver's initial Hessian (built on its first substep).
  const InitialHessian& initialHessian() const { return initialHessian_; }

 private:
  /// One implicit substep of size h over the fraction [fractionStart, fractionEnd] of the step;
  /// on failure returns false with report.error set.
  bool substep(const StepInput& input, State& state, double h, int remaining,
               double fractionStart, double fractionEnd, VectorX& pinForce, StepReport& report);
  /// Phi for the substep: the scheme's coefficients and the terms the scene has.
  void buildPotential(const StepInput& input, const State& state, double h, double fractionStart,
                      double fractionEnd);
  /// The first Newton iterate (evaluated there); false if every candidate leaves a material's
  /// domain.
  bool startingPoint(const StepInput& input, const State& state, int remaining, StepReport& report);
  /// The solver's iterations until converged; false (report.error set) if they fail.
  bool solve(const StepInput& input, const State& state, double h, StepReport& report);
  /// L-BFGS for the substep; false if it stalled (Newton takes over from where it stopped).
  bool quasiNewton(const StepInput& input, const NewtonProblem& problem, StepReport& report);
  /// Acceptance test (a) at an iterate whose remaining Newton correction is dx.
  DisplacementError displacementError(const StepInput& input, const State& state, double h,
                                      const NewtonIterate& it, const VectorX& dx);
  /// The unbalanced forces dPhi/dx / c^2 at an iterate against their scale (reported).
  ForceResidual residual(const StepInput& input, const State& state, double h,
                         const NewtonIterate& it);
  std::string residualText(const ForceResidual& r) const;
  /// Books the converged substep into the state and the report.
  void commit(State& state, double h, VectorX& pinForce, StepReport& report);

  ImplicitScheme scheme_;
  NewtonSolver newton_;
  ImplicitSolver solverKind_;
  QuasiNewtonSolver lbfgs_;
  InitialHessian initialHessian_;
  IncrementalPotential potential_;
  ElasticTerm elastic_;
  LoadTerm loads_;
  MassDampingTerm massDamping_;
  StiffnessDampingTerm stiffnessDamping_;
  AirTerm airTerm_;
  BarrierTerm barrierTerm_;
  FrictionTerm frictionTerm_;
  double sizeScale_ = 0.0;  // rest bounding-box diagonal (m)
  NewtonIterate iterate_;
  // The substep's scene.
  Model* model_ = nullptr;
  const std::vector<char>* pinned_ = nullptr;
  ContactModel* contact_ = nullptr;
  AirModel* air_ = nullptr;  // null: no air term in Phi
  bool massDamped_ = false, stiffnessDamped_ = false;
  // Scratch, sized once.
  VectorX xTrial_, unbalancedForce_, velocity_, vNew_;
};

/// Whether `integrator` is an implicit stepper solving by L-BFGS (integrator.solver: lbfgs),
/// whose summaries count L-BFGS iterations beside Newton's.
bool solvesByLbfgs(const Integrator& integrator);

}  // namespace fem_cloth
