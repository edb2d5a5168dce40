// The simulator: state (x, v), pins and external forces as commands, one integrator, and the
// energy bookkeeping that lets a run check its own energy balance.
//
// Every step either succeeds or leaves the state exactly as it was. An attempt is accepted only
// when it is right (integrators/acceptance.h): finite, converged by the unbalanced forces it
// leaves, creating no energy beyond the work put in, and with every element inside its model's
// domain and validity range. A failed attempt is rolled back and retried with twice the
// substeps, up to maxRetries times; after that step() returns an error naming the test that
// failed and by how much, and the simulator keeps its last good state. A refusal that more
// substeps cannot change (StepReport::retryable false: symplectic Euler asked not to substep
// past its stability bound, XPBD on a term without constraint form) is returned at once.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fem_cloth/core/air.h"
#include "fem_cloth/core/contact/contact_model.h"
#include "fem_cloth/core/contact/projection_contact.h"
#include "fem_cloth/core/integrators/integrator.h"

namespace fem_cloth {

struct SimulatorSettings {
  Eigen::Vector3d gravity{0.0, 0.0, -9.81};  ///< m/s^2 (planar meshes use the first two)
  Damping damping;
  double dt = 1.0 / 60.0;  ///< s, the step taken by step()
  int minSubsteps = 1;     ///< substeps every step starts with
  int maxRetries = 4;      ///< rollbacks per step, each doubling the substeps
  /// The tests every attempt must pass (integrators/acceptance.h).
  AcceptanceSettings acceptance;
};

/// Energies in joules. The balance error is the drift of
///   kinetic + strain + bending + gravity + contactEnergy - externalWork - pinWork - contactWork
///   - airWork - liveWork + dissipated
/// since the start (or the last reset); zero for the exact solution. It is split by the sign of
/// each step's share: balanceError = created - numericalDissipation, where numericalDissipation
/// is what the steps lost beyond the damping model and friction (expected of the implicit schemes, XPBD and
/// projective dynamics) and created what they gained (each step's gain is bounded by the
/// acceptance, test (b); symplectic Euler's energy oscillates, so it has both).
struct EnergyReport {
  double kinetic = 0.0;
  double strain = 0.0;
  double bending = 0.0;
  double gravity = 0.0;  ///< potential relative to the initial positions
  double externalWork = 0.0;
  double pinWork = 0.0;
  /// Work the obstacles did on the cloth, measured: each contact force (barrier or projection,
  /// friction included) times the motion of the obstacle's surface point under it. 0 while
  /// they rest; self-contact does none (its forces are internal).
  double contactWork = 0.0;
  /// The contact barriers' stored energy (implicit steppers), as its change since the start
  /// (or the last reset); part of total.
  double contactEnergy = 0.0;
  double airWork = 0.0;  ///< by the air (core/air.h): < 0 when it only drags, > 0 when wind pushes
  /// Put in by live changes (core/live_change.h): at each, the jump of the stored energy at the
  /// state it was made in (stiffer cloth, other gravity), as work done by whoever changed it.
  double liveWork = 0.0;
  double dissipated = 0.0;  ///< by the damping model and by friction (implicit steppers)
  double total = 0.0;  ///< kinetic + strain + bending + gravity + contactEnergy
  /// The total at the start (or the last reset), measured with the current parameters (a live
  /// change re-measures it and books the difference in liveWork): balanceError is
  /// total - the works + dissipated - initialTotal.
  double initialTotal = 0.0;
  double balanceError = 0.0;
  double numericalDissipation = 0.0;  ///< >= 0: lost by the steps that lost energy
  double created = 0.0;               ///< >= 0: gained by the steps that gained energy
  /// The run's energy scale of acceptance (b) (J): the larger of weight x size, the most
  /// kinetic + elastic energy held and the work put in. The energy a live change put into the
  /// kinetic + elastic energy is not counted (the scale of a check is not inflated by what it
  /// checks: a cloth made 1000 x stiffer holds 1000 x the strain energy in the same shape, and 5 %
  /// of that let symplectic Euler create 11.5 J in a 13.9 J cloth unrefused, issue 31). The net energy
  /// created (balanceError when positive) may not exceed AcceptanceSettings::runEnergyTolerance of it.
  double energyScale = 0.0;
  /// Steps whose pins did more work than Simulator::kPinJumpWork x the cloth's energy scale at
  /// their start: pin jumps, each flagged in its StepReport::warning.
  int pinJumps = 0;
};

/// Acceptance (b) over the run, judged on a run's energies: the net energy created
/// (balanceError when positive) against `tolerance` (AcceptanceSettings::runEnergyTolerance) x
/// the run's energy scale. The one judgement every summary of a run gives (fem_cloth_sim --scene
/// and --commands, the node's /diagnostics), so they agree on what is within tolerance.
struct BalanceJudgement {
  double created = 0.0;    ///< net energy created (J, >= 0)
  double scale = 0.0;      ///< the run's energy scale (J, > 0)
  double tolerance = 0.0;  ///< the largest created / scale accepted
  double fraction() const { return created / scale; }
  bool ok() const { return !(created > tolerance * scale); }
  /// "energy created (net) X J = Y % of the energy scale Z J (at most T % accepted)".
  std::string text() const;
  /// What a user is told when !ok(): the numbers, and that the run's energies are not to be trusted.
  std::string warning() const;
};
BalanceJudgement judgeBalance(const EnergyReport& energies, double tolerance);

class Simulator {
 public:
  /// A pin jump: an accepted step whose pins did more work than this many times the cloth's
  /// energy scale at its start (the larger of weight x size and the kinetic + elastic energy it
  /// held). Such a step is right for the motion commanded (the work is booked, and converges
  /// with the substeps), so it is accepted — more substeps cannot change a motion the pins
  /// prescribe, and refusing it would refuse every later step too — but it is flagged
  /// (StepReport::warning, EnergyReport::pinJumps): a pin target far from its vertex drags the
  /// vertex there within one step, and on the default cloth a 0.3 m jump puts in 36 times its
  /// energy scale (docs/node.md, Commands). A grasp that lifts a cloth does a small part of it
  /// per step.
  static constexpr double kPinJumpWork = 1.0;

  Simulator(std::shared_ptr<Model> model, std::unique_ptr<Integrator> integrator,
            SimulatorSettings settings);

  Model& model() { return *model_; }
  const Model& model() const { return *model_; }
  Integrator& integrator() { return *integrator_; }
  const Integrator& integrator() const { return *integrator_; }
  /// Contact: the scene's obstacles (moved through time with the steps), and the one method the
  /// integrator uses on them (IntegratorCapabilities::contact): the barriers with self-contact
  /// (implicit steppers) or projection (explicit ones). Without them (the default) no contact
  /// code runs at all.
  void setContact(std::shared_ptr<ObstacleSet> obstacles, std::unique_ptr<ContactModel> barriers,
                  std::unique_ptr<ProjectionContact> projection = nullptr);
  /// The obstacles; null without contact (an empty set with self-contact only).
  ObstacleSet* obstacles() { return obstacles_.get(); }
  const ObstacleSet* obstacles() const { return obstacles_.get(); }
  /// The barrier contact (implicit steppers), or null.
  ContactModel* contact() { return contact_.get(); }
  const ContactModel* contact() const { return contact_.get(); }
  /// Aerodynamic drag and lift. Without it (the default) no air code runs at all.
  void setAir(std::unique_ptr<AirModel> air);
  const AirModel* air() const { return air_.get(); }
  const SimulatorSettings& settings() const { return settings_; }
  /// Replaces the acceptance tests' settings (experiments only: see AcceptanceSettings).
  void setAcceptance(const AcceptanceSettings& settings);
  const State& state() const { return state_; }
  double time() const { return state_.time; }
  int dim() const { return model_->dim(); }

  /// Replaces positions (and velocities, zero if empty); both must be finite and sized d*n.
  /// The new state becomes the reference of the energy balance and of reset().
  Status setInitialState(const VectorX& x, const VectorX& v = VectorX());
  /// Back to the initial state, pins and forces (those present when it was set) and time 0.
  void reset();
  /// Takes over where `from` (the simulator of the same mesh before a live change of its
  /// parameters) is: state and history, time and step, pins, forces, what reset() restores, the
  /// substep adaptivity and the energy bookkeeping, the energy the change puts in booked as
  /// liveWork. Only for core/live_change.h, which builds this simulator from the changed scene.
  void continueFrom(Simulator& from);

  // --- Commands (between steps) ---------------------------------------------------------------
  /// Pins a vertex at a target (m) that from now on moves with `velocity` (m/s): the pin follows
  /// p(t) = target + velocity (t - now), and at the end of every step the vertex is at p. A
  /// vertex away from the target gets there within the next step.
  Status pin(Index vertex, const Eigen::Vector3d& target,
             const Eigen::Vector3d& velocity = Eigen::Vector3d::Zero());
  /// Pins a vertex where it is now.
  Status pinInPlace(Index vertex);
  Status release(Index vertex);
  void releaseAll();
  bool isPinned(Index vertex) const;
  std::vector<Index> pinnedVertices() const;
  /// Where the pin of a pinned vertex is now (m; zeros beyond dim).
  Eigen::Vector3d pinTarget(Index vertex) const;
  /// Adds a force (N) on a vertex for `duration` seconds (infinity: until cleared), replacing
  /// an earlier force on the same vertex.
  Status applyForce(Index vertex, const Eigen::Vector3d& force,
                    double duration = std::numeric_limits<double>::infinity());
  Status clearForce(Index vertex);
  void clearForces();
  /// The external force currently applied on each DOF (N).
  const VectorX& externalForce() const { return externalForce_; }

  // --- Stepping -------------------------------------------------------------------------------
  /// One step of settings().dt. On error the state is unchanged.
  StepReport step();
  StepReport step(double dt);
  const StepReport& lastReport() const { return lastReport_; }

  // --- Outputs --------------------------------------------------------------------------------
  /// Evaluates the elastic energies now (one energy evaluation).
  EnergyReport energies();
  /// The run's balance in `e` (energies()) judged against this simulator's run tolerance
  /// (AcceptanceSettings::runEnergyTolerance).
  BalanceJudgement balance(const EnergyReport& e) const {
    return judgeBalance(e, settings_.acceptance.runEnergyTolerance);
  }
  /// Force the cloth exerts on each pinned DOF (N; zero on free DOFs): minus the force the pins
  /// apply, from the last step.
  VectorX pinReactions() const { return -pinForce_; }

 private:
  Status checkVertex(Index vertex) const;
  /// 1/2 v^T M v (J).
  double kineticEnergy(const VectorX& v) const;
  /// Kinetic + elastic - gravity . x at the current state (one energy evaluation), without the
  /// contact barriers' energy.
  double mechanicalEnergy();
  /// Kinetic + elastic energy of a state (J): the balance's reference at the initial state.
  double storedEnergy(const State& s);
  void rebuildExternalForce();
  void snapshotInitial();
  /// The energy account and the pin forces start again from zero (a new initial state, reset).
  void restartAccount();
  /// Forces whose duration ended before a step of dt from now no longer act.
  void dropExpiredForces(double dt);
  /// The substeps a step starts with: the adaptive count, halved after kRelaxAfter clean steps.
  int startingSubsteps();
  StepInput stepInput(double dt);
  /// One attempt of the integrator, checked: finite, then tests (a)-(c) (accept); fills `energy`.
  StepReport attempt(const StepInput& input, double dt, int substeps, double energyStart,
                     EnergyStep& energy);
  /// Tests (a)-(c) of an attempt that the integrator reported done; fills `energy`.
  Status accept(const StepReport& r, double energyStart, EnergyStep& energy);
  /// A step whose attempts all failed: the report says why; pins and energy as before it.
  StepReport failed(StepReport total, int substeps, const std::string& firstError, double energyStart);
  /// Kinetic + elastic energy at the start of the step being taken (energyStart is mechanical).
  double heldAtStart(double energyStart) const { return energyStart + gravityForce_.dot(backup_.x); }
  /// Flags an accepted step as a pin jump (kPinJumpWork) in r.warning, before it is committed.
  void flagPinJump(StepReport& r, double energyStart, double dt);
  /// Books an accepted step (energy account, pins, time).
  void commit(const StepReport& r, const EnergyStep& energy, double dt);

  std::shared_ptr<Model> model_;
  std::unique_ptr<Integrator> integrator_;
  std::shared_ptr<ObstacleSet> obstacles_;
  std::unique_ptr<ContactModel> contact_;
  std::unique_ptr<ProjectionContact> projection_;
  std::unique_ptr<AirModel> air_;
  SimulatorSettings settings_;
  StepAcceptance acceptance_;
  State state_;
  State backup_;
  // The mechanical energy of state_, the contact barriers' energy included, when known: the end
  // of one step is the start of the next (the state changes only in step, setInitialState and
  // reset); contactNow_ is the barriers' part of it. Both are forgotten together (forgetEnergy).
  std::optional<double> energyNow_, contactNow_;
  void forgetEnergy() {
    energyNow_.reset();
    contactNow_.reset();
  }
  /// The contact barriers' energy at state_ with the obstacles at the start of the step being
  /// taken (J; 0 without barriers): contactNow_, measured if not known.
  double contactEnergyNow();
  // The reference acceleration of test (a) (m/s^2): accelerationScale(|g|), or the mean
  // acceleration the commanded forces give the cloth if larger (rebuildExternalForce).
  double referenceAcceleration_ = kStandardGravity;
  VectorX gravityForce_;
  std::vector<char> pinned_;
  VectorX pinTarget_, pinVelocity_;  // pin positions now, and their velocities
  VectorX stepPinTarget_;             // pin positions at the end of the step being taken
  struct Force {
    Index vertex;
    Eigen::Vector3d force;
    double expiresAt;
  };
  std::vector<Force> forces_;
  VectorX externalForce_;
  VectorX pinForce_, previousPinForce_;
  StepReport lastReport_;
  // Energy bookkeeping: the account since the initial state (J), reset and copied as a whole
  // (snapshotInitial, reset, continueFrom), and the balance's reference, the kinetic + elastic
  // energy of initial_.state.
  struct EnergyBook {
    double externalWork = 0.0, pinWork = 0.0, contactWork = 0.0, airWork = 0.0;
    double contactEnergy = 0.0;  // change of the contact barriers' energy since the start
    double liveWork = 0.0;    // put in by live changes (continueFrom)
    double liveHeld = 0.0;    // of it, the jump of the kinetic + elastic energy (not in the scale)
    double dissipated = 0.0;  // by the damping model
    double numerical = 0.0;   // lost by the steps that lost energy (>= 0)
    double created = 0.0;     // gained by the steps that gained energy (>= 0)
    double heldMost = 0.0;    // the most kinetic + elastic energy an accepted step held, less liveHeld
    int pinJumps = 0;         // steps flagged by flagPinJump
    /// Books an accepted step.
    void add(const EnergyStep& step);
  } book_;
  double initialTotal_ = 0.0;
  /// The run's energy scale of acceptance (b), with the work and held energy of `step` added
  /// (EnergyStep{}: the account's own).
  double runEnergyScale(const EnergyStep& step) const;
  double sizeScale_ = 0.0;  // total weight x bounding-box diagonal of the rest mesh (J)
  bool energyRefused_ = false;  // the last accept() failed an energy test (b)
  double lengthScale_ = 0.0;  // bounding-box diagonal of the rest mesh (m)
  // Substep adaptivity: a step that needed more substeps than the minimum sets the count the
  // next steps start with; after kRelaxAfter clean steps the count is halved again.
  int currentSubsteps_ = 1;
  int cleanSteps_ = 0;
  static constexpr int kRelaxAfter = 20;
  // What reset() restores.
  struct Initial {
    State state;
    std::vector<char> pinned;
    VectorX pinTarget, pinVelocity;
    std::vector<Force> forces;
  } initial_;
};

}  // namespace fem_cloth
