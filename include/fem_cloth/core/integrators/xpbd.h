// Extended position-based dynamics (Macklin, Mueller & Chentanez, "XPBD: Position-Based
// Simulation of Compliant Constrained Dynamics", 2016) applied to the FEM energy itself.
//
// Every element of every term (a membrane triangle, a bending hinge) is one block of compliant
// constraints: its energy is written exactly as U_e = 1/2 C_e^T K_e C_e (the materials' constraint
// form), so the compliance is alpha_e = K_e^-1 and the constraint potential is the element's FEM
// energy, for any material model. Compared with the energy-based triangle constraint of the
// PositionBasedDynamics library (Bender, Koschier, Charrier & Weber 2014), the constraints are
// signed (no cusp at rest) and compliant, which makes the result independent of the iteration
// count and substep size in the limit: converged, XPBD solves the backward Euler equations. With
// few iterations the cloth is softer than its material (the solve has not converged); the
// accuracy report measures how much.
//
// Gauss-Seidel over the elements in mesh order: sequential and deterministic.
// Damping: mass-proportional alpha is implicit as in backward Euler (the predicted velocity is
// divided by 1 + h alpha and the projection uses the masses times 1 + h alpha, so converged XPBD
// still solves the damped backward Euler equations); stiffness-proportional beta uses XPBD's
// constraint damping (section 3.5).
// Obstacles (when the scene has any) are inequality constraints projected after every sweep,
// with Coulomb friction at the end of each substep (contact/projection_contact.h).
#pragma once

#include "fem_cloth/core/air.h"
#include "fem_cloth/core/integrators/integrator.h"

namespace fem_cloth {

struct XpbdSettings {
  /// Gauss-Seidel sweeps per substep before the forces are first checked; more follow, as many
  /// at a time, until they balance (acceptance test (a)) or maxIterations are spent.
  int iterations = 10;
  int maxIterations = 100;
  int substeps = 1;     ///< substeps per step
};

class Xpbd final : public Integrator {
 public:
  explicit Xpbd(XpbdSettings settings = {}) : settings_(settings) {}
  std::string name() const override { return "xpbd"; }
  bool needsHessian() const override { return false; }
  StepReport step(const StepInput& input, State& state, double dt, int minSubsteps,
                  VectorX& pinForce) override;
  /// After a rollback or a new state, the next substep starts its displacements from zero.
  void invalidate() override { lambdaStep_ = 0.0; }

 private:
  void cacheStiffness(Model& model);
  /// Starts the elements' displacements of a substep of size h from the last substep's and
  /// applies them to the predicted positions x (from zero after invalidate()).
  void warmStart(Model& model, VectorX& x, double h, double dampedMass);
  /// One Gauss-Seidel sweep over every element of every term; false (report.error set) if an
  /// element leaves its domain.
  bool sweep(Model& model, VectorX& x, double h, double betaH, StepReport& report);
  /// Acceptance test (a) at x: the unbalanced force of XPBD's equations (elasticForce_ holds
  /// the elastic and damping part, velocity_ the substep's velocities).
  ForceResidual residual(const StepInput& input, const VectorX& x, double h, double dampedMass,
                         double betaH);
  // Contact per substep (only with obstacles); kept out of step() (see xpbd.cpp).
  [[gnu::noinline]] void beginContactSubstep(ProjectionContact& contact, int substep, int substeps);
  [[gnu::noinline]] void finishContactSubstep(ProjectionContact& contact, VectorX& x, double h,
                                              double dampedMass, StepReport& report);

  XpbdSettings settings_;
  VectorX xStart_, vStart_, inverseMass_;
  LaggedAir air_;  // air only
  VectorX xPredicted_, elasticForce_, unbalanced_, velocity_;
  std::uint64_t contactChecksBefore_ = 0;
  const Model* stiffnessModel_ = nullptr;
  std::vector<std::vector<double>> stiffness_;  // per term: K_e, row-major, per element
  std::vector<std::vector<double>> applied_;    // per term: W G^T lambda applied, per element
  // The substep (s) and mass factor 1 + h alpha applied_ belongs to; 0: none (cold start).
  double lambdaStep_ = 0.0, lambdaDampedMass_ = 1.0;
};

}  // namespace fem_cloth
