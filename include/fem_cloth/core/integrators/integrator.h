// The interface shared by all time integrators, and what a step reports.
//
// Pins are hard constraints: pinned DOFs are moved kinematically from their start-of-step
// position to their end-of-step target (linearly within substeps) and are removed from every
// solve; they are never stiff springs.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "fem_cloth/core/expected.h"
#include "fem_cloth/core/integrators/acceptance.h"
#include "fem_cloth/core/model.h"

namespace fem_cloth {

class AirModel;
class ContactModel;
class ProjectionContact;

/// Rayleigh damping: the damping force is -(alpha M + beta K) v, with K the (PSD-projected)
/// stiffness. alpha (1/s) damps all motion like air drag; beta (s) damps fast elastic
/// oscillations. Both zero: no damping term is evaluated at all.
struct Damping {
  double massProportional = 0.0;       ///< alpha, 1/s
  double stiffnessProportional = 0.0;  ///< beta, s
  bool any() const { return massProportional > 0.0 || stiffnessProportional > 0.0; }
};

/// The dynamic state. BDF2 needs the previous step as well.
///
/// The history (xPrevious, vPrevious) is usable only while it is smooth: a change of step size
/// drops it (historyDt no longer matches), and so does an impact, more contacts at the end of a
/// substep than at the end of the one before, for that substep and the next ones whose history
/// still holds the velocity jump (ImplicitIntegrator::step). Both travel with the state, so a
/// rolled-back step, a reset or a copy restores them with it.
struct State {
  VectorX x;  ///< positions (m), flat
  VectorX v;  ///< velocities (m/s), flat
  VectorX xPrevious;  ///< positions one step earlier (empty if there is no history)
  VectorX vPrevious;
  double historyDt = 0.0;  ///< step size that separates x and xPrevious; 0: no history
  double time = 0.0;       ///< s
  std::uint64_t step = 0;
  int contacts = 0;  ///< contacts at the end of the last substep (0 without contact handling)
  int unsmoothSubsteps = 0;  ///< substeps still to start without history (after an impact)
  bool hasHistory() const { return xPrevious.size() == x.size() && historyDt > 0.0; }
  /// A history a BDF2 substep of size h can use: there is one, and it is h apart.
  bool hasHistoryFor(double h) const { return hasHistory() && std::abs(historyDt - h) <= 1e-12 * h; }
  void clearHistory() {
    xPrevious.resize(0);
    vPrevious.resize(0);
    historyDt = 0.0;
    contacts = unsmoothSubsteps = 0;
  }
  /// Before a substep: drops the history if an impact is still in it.
  void beginSubstep() {
    if (xPrevious.size() != x.size()) contacts = unsmoothSubsteps = 0;  // a new run
    if (unsmoothSubsteps > 0) {
      historyDt = 0.0;
      --unsmoothSubsteps;
    }
  }
  /// An impact at the end of the last substep: the history holds it for `substeps` more.
  void impact(int substeps) { unsmoothSubsteps = substeps; }
};

/// Everything a step needs besides the state. Vectors are per DOF.
struct StepInput {
  Model* model = nullptr;
  const VectorX* gravityForce = nullptr;   ///< m_i g, N
  const VectorX* externalForce = nullptr;  ///< commanded forces, constant over the step, N
  const std::vector<char>* pinned = nullptr;  ///< per DOF: 1 if pinned
  const VectorX* pinTarget = nullptr;  ///< end-of-step positions of pinned DOFs (m)
  Damping damping;
  /// Contact, by the method the integrator declares (IntegratorCapabilities::contact): the
  /// barriers and self-contact (contact/contact_model.h) or the projection onto obstacles
  /// (contact/projection_contact.h). Null when the scene has neither obstacles nor
  /// self-contact, and then no contact code runs at all.
  ContactModel* contact = nullptr;
  ProjectionContact* projection = nullptr;
  /// Aerodynamic drag and lift (core/air.h); null when the scene has no `air`, and then no air
  /// code runs at all.
  AirModel* air = nullptr;
  /// What the unbalanced forces a solver leaves are measured against (acceptance.h, test (a)):
  /// iterative solvers iterate until measureResidual() is within the tolerance.
  ResidualScale residualScale;
  /// The implicit steppers' test (a) in displacement (acceptance.h), its floor in metres.
  DisplacementTolerance displacement;
  /// The energy acceptance test (b) lets the whole step create at least (J; Simulator::step
  /// sets it): test (a) also bounds the energy the remaining correction would change by
  /// displacement.ratio x this, shared over the substeps.
  double energyBudget = std::numeric_limits<double>::infinity();
};

/// Where a Newton solve's time went (s of wall time, steady clock): what scripts/bench and
/// fem_cloth_sim's summary print, so that a profile of the implicit steps is always at hand.
struct NewtonTimes {
  double assembly = 0.0;       ///< gradient and projected Hessian of Phi, pins eliminated
  double factorisation = 0.0;  ///< sparse Cholesky (and its analysis when the pattern changed)
  double solve = 0.0;          ///< triangular solves
  double bound = 0.0;          ///< the step bound: broad phase and continuous collision detection
  double search = 0.0;         ///< line search: Phi and its gradient at the trial points
  double total() const { return assembly + factorisation + solve + bound + search; }
  NewtonTimes& operator+=(const NewtonTimes& o) {
    assembly += o.assembly;
    factorisation += o.factorisation;
    solve += o.solve;
    bound += o.bound;
    search += o.search;
    return *this;
  }
};

/// What a step did. Counts add up over substeps and retries.
struct StepReport {
  bool ok = true;
  std::string error;       ///< why the step failed (state untouched)
  /// An accepted step that is right but not what its commands should have asked for (a pin jump,
  /// Simulator::kPinJumpWork); empty when there is nothing to say.
  std::string warning;
  /// False when more substeps cannot help (a step size the settings refuse, a model the
  /// integrator cannot handle): the simulator then returns the error without retrying.
  bool retryable = true;
  /// m: the deepest the cloth's surface reached into a box between its vertices over the
  /// substeps (ContactStats::boxDepth; at least), and where; 0 and empty when it did not.
  double boxDepth = 0.0;
  std::string boxDepthWhere;
  int substeps = 0;
  int newtonIterations = 0;
  /// L-BFGS iterations (integrator.solver: lbfgs); substeps where it stalled or Newton's check refused its solution
  /// and Newton finished (newtonIterations counts the check, one Hessian factorised, and Newton's iterations).
  int quasiNewtonIterations = 0;
  int solverFallbacks = 0;
  /// The unbalanced force the solver left (acceptance test (a)), the worst over the substeps;
  /// zero for symplectic Euler, which solves no equation.
  ForceResidual unbalanced;
  /// The implicit steppers' error in displacement (acceptance test (a)), the worst over the
  /// substeps; not measured by the others.
  DisplacementError displacement;
  double residual = 0.0;   ///< largest unbalanced force (N, over free DOFs): unbalanced.largest
  int lineSearchBacktracks = 0;
  NewtonTimes newtonTimes;  ///< implicit steppers: where the Newton solves' time went
  int rollbacks = 0;       ///< failed attempts that were undone and retried
  /// Of those, the ones retried with the same substeps and a 100x tighter test (a): a step
  /// within test (a) that test (b) refused as creating energy (Simulator::step).
  int tightened = 0;
  bool energyRefused = false;  ///< the attempt failed test (b), energy created
  int iterations = 0;  ///< local solver iterations (XPBD sweeps, projective dynamics iterations)
  double dissipated = 0.0;  ///< energy removed by the damping model and by friction in this step (J)
  /// Work of the pins on the cloth in this step (J): each substep's pin force (the one its
  /// equations of motion hold at their end) times the pins' displacement in it; symplectic and
  /// backward Euler book the pinned vertices' kinetic energy exactly (step_common.h,
  /// pinWorkInSubstep), so that a pin that starts or stops at once is balanced too.
  double pinWork = 0.0;
  double dtUsed = 0.0;      ///< the (sub)step size of the last successful attempt (s)
  int contacts = 0;         ///< contacts at the end of the step (closer than the contact distance)
  std::uint64_t contactChecks = 0;  ///< distance evaluations for contact; 0 without contact
  /// Work the obstacles did on the cloth (J): each contact force on the cloth (barrier or
  /// projection, friction included) times the motion of the obstacle's surface point under it
  /// (ContactStats::work); 0 for resting obstacles and for self-contact. Friction's loss is in
  /// `dissipated`, the barriers' energy in contactEnergy.
  double contactWork = 0.0;
  /// Energy stored in the contact barriers at the end of the step (J; implicit steppers, which
  /// have barriers; 0 for the others): part of the energy acceptance (b) balances.
  double contactEnergy = 0.0;
  /// Work of the air on the cloth (J; negative when it only drags, positive when wind pushes):
  /// each substep's air force times the displacement in it.
  double airWork = 0.0;
  /// Smallest vertex-obstacle or self-contact distance the step ended with (m; inf if none near).
  double minContactDistance = std::numeric_limits<double>::infinity();
};

class Integrator {
 public:
  virtual ~Integrator() = default;
  virtual std::string name() const = 0;
  /// Implicit steppers assemble Hessians; the others never ask for one.
  virtual bool needsHessian() const = 0;
  /// Advances `state` by dt with at least `minSubsteps` substeps, writing into pinForce (per
  /// DOF, resized by the caller) the force the pins exert on the cloth at the end of the step.
  /// On failure the report says why; the caller restores the state.
  virtual StepReport step(const StepInput& input, State& state, double dt, int minSubsteps,
                          VectorX& pinForce) = 0;
  /// Called when the topology, pins or stiffness change enough to redo set-up work.
  virtual void invalidate() {}
  /// Acceptance test (b): how much energy the last step may have created beyond the work put in
  /// (forces, pins, contact) and the damping removed, as a fraction of the energy scale (the
  /// larger of weight x cloth size, the energy the cloth holds and the work of the step). A
  /// converged implicit step loses energy (numerical dissipation) and creates it only where the
  /// energy is not convex, by a second-order amount; the default allows 1e-3 of the scale.
  virtual double energyTolerance() const { return kEnergyTolerance; }
  static constexpr double kEnergyTolerance = 1e-3;
};

}  // namespace fem_cloth
