// When a step is accepted (issue 11; docs/integrators.md, "Acceptance"): one check the Simulator
// runs after every attempt of every integrator, with three tests, and a refusal that names the
// test that failed and by how much.
//
//  (a) Converged: the unbalanced force the solver leaves on every free DOF is small against the
//      forces that DOF sees. Each integrator measures the residual r of the equations of motion
//      it discretises (the gradient of the incremental potential for the implicit ones, the same
//      equations for projective dynamics and XPBD; exactly zero for symplectic Euler, which solves
//      nothing) with measureResidual(), against the scale
//          s_i = m_i (a + max(|v_i|, |v_i+|) / h) + |f_i|,
//      the vertex's weight at the scene's reference acceleration a (gravity, at least 9.81 m/s^2,
//      or the mean acceleration the commanded forces give the cloth if larger), its inertia (the
//      force that stops it within the substep h) and the force commanded on it. Accepted when
//      |r_i| <= tolerance x s_i for every free DOF: the velocity error the residual makes in a
//      substep, h r_i / m_i, is then at most 1 % (the default) of the vertex's speed plus what
//      the reference acceleration adds in the substep.
//  (b) No energy created: over the step, the mechanical energy (kinetic + elastic + gravitational)
//      may not grow by more than the work put in (commanded forces, pins, contact, air) minus what the
//      damping model removed, beyond the integrator's bound (Integrator::energyTolerance()) times
//      the energy scale (the larger of weight x size, the energy the cloth holds and the work of
//      the step). What is lost beyond the damping model is numerical dissipation, expected of the
//      implicit schemes and booked as its own term (EnergyReport::numericalDissipation).
//      Over the run too: the net energy the accepted steps created since the start (the balance
//      error) may not exceed runEnergyTolerance (5 %) of the run's energy scale (the larger of
//      weight x size, the most the cloth held and the work put in so far). A stable scheme's
//      error oscillates without drift (symplectic Euler's modified energy, Hairer, Lubich &
//      Wanner IX.8); slow growth, which stays under the per-step bound, is caught here.
//  (c) Valid: every element is inside its model's validity range (EnergyTerm::validity; the
//      linear membrane's small-deformation range, materials/linear.h). Models without a range
//      cost nothing here. (Domains, such as Neo-Hookean's J > 0, are enforced by the solvers.)
//
// A step that fails any test is rolled back and retried with twice the substeps; when retries
// run out it is refused with the message, and the state stays the last accepted one.
#pragma once

#include <string>
#include <vector>

#include "fem_cloth/core/conventions.h"
#include "fem_cloth/core/expected.h"

namespace fem_cloth {

class Model;
struct StepReport;

/// The residual of (a) at its worst free DOF.
struct ForceResidual {
  double relative = 0.0;  ///< |r_i| / s_i, largest over free DOFs (0: exact, or nothing free)
  double force = 0.0;     ///< |r_i| there (N)
  double scale = 0.0;     ///< s_i there (N)
  Index dof = -1;         ///< where (-1: no free DOF measured)
  double largest = 0.0;   ///< largest |r_i| over free DOFs (N), wherever it is
  /// Keeps the worse of the two (a step's residual is its worst substep's).
  void merge(const ForceResidual& other);
};

/// What (a) measures against, set by the simulator for every step.
struct ResidualScale {
  double acceleration = kStandardGravity;  ///< a (m/s^2)
  double tolerance = 1e-2;                 ///< largest |r_i| / s_i accepted
};

/// (a)'s measure of a residual force r (N per DOF, pinned DOFs ignored) of a substep of length h
/// whose DOFs had velocities vStart and end with vEnd; externalForce: the commanded forces.
ForceResidual measureResidual(const VectorX& residual, const VectorX& mass,
                              const VectorX& externalForce, const std::vector<char>& pinned,
                              const VectorX& vStart, const VectorX& vEnd, double h,
                              double acceleration);

/// The settings of the three tests.
struct AcceptanceSettings {
  double forceTolerance = 1e-2;  ///< (a): see ResidualScale::tolerance
  /// (b) and (c) can be switched off for experiments that want to see a model or a scheme fail
  /// (a blow-up, a linear membrane far outside its range); never in normal use.
  bool energy = true;
  bool validity = true;
  /// (b) over the run: net energy created since the start / the run's energy scale.
  double runEnergyTolerance = 0.05;
};

/// The energy account of one attempt (J), as the simulator books it.
struct EnergyStep {
  /// Mechanical energy before and after: kinetic + elastic + gravity + the contact barriers'.
  double start = 0.0, end = 0.0;
  double contactStored = 0.0;     ///< of end - start, the change of the contact barriers' energy
  double held = 0.0;              ///< kinetic + elastic energy held (the larger of before, after)
  double externalWork = 0.0, pinWork = 0.0, contactWork = 0.0, airWork = 0.0;  ///< work put in
  double dissipated = 0.0;        ///< removed by the damping model and by friction
  double work() const { return externalWork + pinWork + contactWork + airWork; }
  /// Energy the attempt created (negative: numerical dissipation).
  double created() const { return end - start - work() + dissipated; }
};

class StepAcceptance {
 public:
  explicit StepAcceptance(AcceptanceSettings settings = {}) : settings_(settings) {}
  const AcceptanceSettings& settings() const { return settings_; }

  /// (a) The attempt's residual (StepReport::unbalanced) against the tolerance.
  Status converged(const StepReport& report, int dim) const;
  /// (b) energy.created() against tolerance x scale, scale = max(sizeScale, held, |work()|).
  Status energyConserved(const EnergyStep& energy, double tolerance, double sizeScale) const;
  /// (b) over the run: createdBefore (net, J, the accepted steps') + energy.created() against
  /// runEnergyTolerance x runScale.
  Status runEnergyConserved(double createdBefore, const EnergyStep& energy, double runScale) const;
  /// (c) Every element of the model inside its validity range at x.
  Status valid(Model& model, const VectorX& x) const;

 private:
  AcceptanceSettings settings_;
};

}  // namespace fem_cloth
