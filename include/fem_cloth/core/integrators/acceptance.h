// When a step is accepted (issue 11; docs/integrators.md, "Acceptance"): one check the Simulator
// runs after every attempt of every integrator, with three tests, and a refusal that names the
// test that failed and by how much.
//
//  (a) Converged. The Newton steppers (backward Euler, BDF2) measure the error of their solution
//      in displacement, against the scheme's own error: the correction dx = H^-1 r Newton's
//      factorised Hessian H makes of the residual r of the equations of motion is the distance to
//      the exact solution of the step, to first order. Accepted when at every free vertex
//          |dx_v| <= min(ratio x tau_v, cap x |x_v+ - x_v|) + floor,
//      tau_v the local truncation error of the step at the vertex, estimated from its velocities
//      (truncationEstimate(): h/2 |v+ - v| for backward Euler, 2h/9 |v+ - 2v + v-| for BDF2), the
//      cap a bound by the vertex's own motion in the step (1 % by default; it keeps an
//      unconverged state out where tau is large, at huge steps), the floor an absolute length
//      (error_floor x the cloth's size). A stiff in-plane direction (1e4 N/m) then needs its
//      force balanced to 1e4 N/m x dx, not to a fraction of the vertex's weight and inertia
//      (issue 29: nanometres). Besides, the change the correction would make to the step's energy
//      balance, |dE/dx . dx| + 1/2 dx^T H dx, must be within ratio x the energy test's bound
//      (test (b), at the step's start, shared over its substeps): near a stiff contact barrier a
//      correction of micrometres is otherwise energy that test (b) refuses, a rollback.
//      The explicit steppers, XPBD and projective dynamics keep the force
//      test below: projective dynamics' constant matrix overstates the stiffness (it majorises
//      the energy), so A^-1 r understates the error of its linearly converging iterations, and
//      the 1 / (1 - theta) below does not rescue it (measured: its iterations crawl); it moves to
//      the displacement test with a quasi-Newton solver whose correction is Newton-like.
//      The force test: the unbalanced force the solver leaves on every free DOF is small against the
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

/// Test (a) in displacement (implicit steppers): |dx_v| <= min(ratio tau_v, cap |motion_v|) + floor.
struct DisplacementTolerance {
  double ratio = 0.1;  ///< of the truncation estimate tau_v (integrator.error_ratio)
  double cap = 0.01;   ///< of the vertex's motion in the substep (integrator.error_cap)
  /// An absolute length (m). In scenes and AcceptanceSettings: in cloth sizes (the rest
  /// bounding-box diagonal; integrator.error_floor); StepInput carries it in metres.
  /// 1e-7: 0.1 um on a 1 m cloth, where a stiff membrane (1e4 N/m) leaves 1e-3 N unbalanced; a
  /// floor of 1e-5 left 0.1 N at the pins of a still, hanging 0.3 m cloth weighing 0.18 N.
  double floor = 1e-7;
};

/// How the velocities of a substep estimate its local truncation error (m per vertex).
struct SubstepMotion {
  const VectorX* xStart = nullptr;  ///< positions at the start of the substep
  const VectorX* xEnd = nullptr;    ///< the solution (m)
  const VectorX* vStart = nullptr;  ///< velocities at the start
  const VectorX* vEnd = nullptr;    ///< at the end
  /// Second order (BDF2 with its history): the velocities one substep before vStart; null for
  /// backward Euler.
  const VectorX* vBefore = nullptr;
  double h = 0.0;
};

/// The local truncation error of the substep at vertex v (m), from its velocities:
///   backward Euler: x+ = x + h v+ against x(t + h) = x + h v + h^2/2 a + O(h^3): error
///     h^2/2 |a| ~ h/2 |v+ - v|;
///   BDF2: error 2/9 h^3 |x'''| ~ 2h/9 |v+ - 2v + v-| (v- one substep before v).
double truncationEstimate(const SubstepMotion& motion, Index vertex, int dim);

/// Test (a) in displacement at its worst free vertex.
struct DisplacementError {
  double relative = 0.0;    ///< |dx_v| / tolerance_v, largest over free vertices
  double error = 0.0;       ///< |dx_v| there (m)
  double tolerance = 0.0;   ///< its tolerance there (m)
  double truncation = 0.0;  ///< tau_v there (m)
  double motion = 0.0;      ///< |x_v+ - x_v| there (m)
  Index vertex = -1;        ///< where (-1: not measured, or nothing free)
  double largest = 0.0;     ///< largest |dx_v| over free vertices (m), wherever it is
  /// The change of the step's energy balance the correction would make (J: first order, and
  /// the second-order term of the Newton decrement), and what it may be (ratio x the step's
  /// share of the energy test's bound): a stiff barrier turns a correction within the
  /// displacement bound into energy that test (b) then refuses.
  double energy = 0.0;
  double energyTolerance = std::numeric_limits<double>::infinity();
  bool measured() const { return vertex >= 0; }
  /// Both within their bounds (false for NaN).
  bool within() const { return relative <= 1.0 && energy <= energyTolerance; }
  /// Keeps the worse of the two (a step's error is its worst substep's).
  void merge(const DisplacementError& other);
  /// The error of a linearly converging iteration (below): the measure of the correction times
  /// remainingErrorFactor(); an infinite factor is an infinite relative error.
  void scale(double factor);
};

/// A correction dx = A^-1 r is the distance to the solution where the iteration converges fast
/// (Newton near the solution). Where it converges only linearly, with contraction theta =
/// |dx| / |the move that reached the iterate| (a Newton whose projected Hessian overstates a
/// nearly flat energy, as in a compressed cloth without bending at a huge step), the corrections still to come add up to |dx| / (1 - theta)
/// (the stopping rule of Newton's iterations in Hairer & Wanner, "Solving Ordinary Differential
/// Equations II", IV.8). Returns 1 / (1 - theta); infinity for theta >= 1 (no convergence); 1 when
/// `moved` is 0 (no move to compare with).
double remainingErrorFactor(double correction, double moved);

/// Test (a)'s measure of a correction dx (per DOF; pinned DOFs ignored) of the substep `motion`.
DisplacementError measureDisplacementError(const VectorX& dx, const SubstepMotion& motion,
                                           const std::vector<char>& pinned, int dim,
                                           const DisplacementTolerance& tolerance);

/// The settings of the three tests.
struct AcceptanceSettings {
  double forceTolerance = 1e-2;  ///< (a): see ResidualScale::tolerance
  DisplacementTolerance displacement;  ///< (a) for the implicit steppers (floor in cloth sizes)
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

  /// (a) The attempt's displacement error (StepReport::displacement) when the integrator
  /// measured one, else its residual (StepReport::unbalanced), against their tolerances.
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
