// Symplectic (semi-implicit) Euler: v+ = v + h M^-1 f(x), x+ = x + h v+.
//
// Explicit and cheap (one gradient per substep, no Hessian, no solve), but only conditionally
// stable: h < 2 / omega_max with omega_max the highest natural frequency of the discretised
// cloth, which grows with stiffness and shrinks with element size (the CFL condition). The
// stepper estimates omega_max^2 = lambda_max(M^-1 K) by power iteration on the PSD stiffness
// and either substeps to stay below the bound (autoSubstep) or refuses a dt above it.
// Undamped, it conserves a modified energy, so the total energy oscillates but does not drift
// (what it measures drifts slowly as fast modes fill up; see cflSafety).
// Mass-proportional damping is treated implicitly (it never limits the step); stiffness-
// proportional damping is explicit and tightens the bound (see stableStep).
// Obstacles (when the scene has any): after each substep, vertices closer than the contact
// distance are projected out to it with Coulomb friction (contact/projection_contact.h).
#pragma once

#include "fem_cloth/core/air.h"
#include "fem_cloth/core/integrators/integrator.h"

namespace fem_cloth {

struct SymplecticEulerSettings {
  bool autoSubstep = true;   ///< substep to stay stable; false: refuse an unstable dt
  /// Fraction of the stability bound used. Undamped, the energy symplectic Euler measures in a
  /// mode of frequency w is its conserved (shadow) energy times 1 / (1 - (h w / 2)^2): near the
  /// bound a cloth that passes energy to its fast modes appears to gain energy, and stiffening
  /// under stretch can push them past it. 0.5 keeps that factor below 4/3.
  double cflSafety = 0.5;
  int maxSubsteps = 1 << 16;
  int boundUpdateInterval = 20;  ///< steps between re-estimates of the bound
};

class SymplecticEuler final : public Integrator {
 public:
  explicit SymplecticEuler(SymplecticEulerSettings settings = {}) : settings_(settings) {}
  std::string name() const override { return "symplectic_euler"; }
  bool needsHessian() const override { return false; }
  StepReport step(const StepInput& input, State& state, double dt, int minSubsteps,
                  VectorX& pinForce) override;
  void invalidate() override { stableStep_ = 0.0; }
  /// Symplectic Euler oscillates around a modified energy: the bound is the largest swing of
  /// the measured energy in a step at the substep the last step took (see the .cpp).
  double energyTolerance() const override;

  /// The largest stable step at positions x (s): 2/omega_max, reduced for stiffness damping
  /// beta to (2/omega)(sqrt(1 + zeta^2) - zeta) with zeta = beta omega / 2.
  double stableStep(Model& model, const VectorX& x, const std::vector<char>& pinned,
                    const Damping& damping);

  /// The bound the stepper currently uses (0 before the first step).
  double currentStableStep() const { return stableStep_; }

 private:
  /// The substeps dt takes at the current bound: at least minSubsteps, more to stay within
  /// cflSafety x the bound; 0 (report failed, not retryable) if it refuses the step.
  int substepsFor(double dt, int minSubsteps, StepReport& report) const;
  /// force_ = gravity + air - dE/dx (- beta K v into dampingForce_) at the substep's start;
  /// false (report.error set) if an element left its domain or the air failed.
  bool substepForces(const StepInput& input, const State& state, double h, StepReport& report);
  /// The obstacles' projection with friction after substep s (contact only).
  void projectContact(const StepInput& input, State& state, int s, int substeps, double h,
                      std::uint64_t checksBefore, StepReport& report);

  SymplecticEulerSettings settings_;
  double stableStep_ = 0.0;
  double stepRatio_ = 0.0;  // the last step's substep over the stable step
  std::uint64_t boundAge_ = 0;
  VectorX force_, gradient_, velocityStart_;
  VectorX shifted_, shiftedGradient_, dampingForce_;  // stiffness damping only
  VectorX invSqrtMass_, powerU_, powerW_, powerS_;    // power iteration (stableStep)
  VectorX positionStart_;  // contact only
  LaggedAir air_;  // air only
};

}  // namespace fem_cloth
