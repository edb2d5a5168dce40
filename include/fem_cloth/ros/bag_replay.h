// Offline re-simulation into a bag, without a ROS master (fem_cloth_sim --commands / --out *.bag).
//
// With a recorded run, its scene (or another), its commands and its tf frames are fed to the same
// SimulationDriver the node uses, at full speed, so every command takes effect at the step it
// did live; each recorded state (positions, velocities where recorded, hash) is compared with the
// re-simulation bit for bit, and a recorded state that cannot be one of the cloth is refused.
// Without one, the scene simply runs and is written out.
#pragma once

#include <array>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "fem_cloth/core/integrators/step_totals.h"
#include "fem_cloth/core/metrics.h"
#include "fem_cloth/core/simulator.h"
#include "fem_cloth/io/recording.h"
#include "fem_cloth/ros/bag_io.h"
#include "fem_cloth/ros/simulation_driver.h"

namespace fem_cloth {

struct BagRunOptions {
  std::string node = "/fem_cloth_node";  ///< the node whose topics are read and written
  std::string sceneFile;                 ///< empty: the scene stored in the input bag
  std::vector<std::string> overrides;    ///< key.path=value on top of the scene
  /// Simulated time (s); 0: up to the last recorded state, or the last command + 1 s, or the
  /// scene's duration.
  double duration = 0.0;
  /// Write every N-th state; 0: the steps the input bag has states for, else about 30 Hz.
  int every = 0;
  bool progress = true;  ///< a progress line on stderr for long runs
};

struct BagRunReport {
  std::string scene;       ///< scene name
  std::string integrator;
  bool lbfgs = false;  ///< the implicit stepper solves by L-BFGS (solvesByLbfgs)
  std::uint64_t steps = 0;
  /// What the steps did (solvers, substeps, worst error, reach into boxes), as a scene run sums it.
  StepTotals stepTotals;
  double simulated = 0.0;  ///< s
  double wall = 0.0;       ///< s
  std::array<std::size_t, kCommandTopics> commands{};  ///< replayed, per command topic
  bool exactCommands = false;  ///< replayed the applied-command stream
  std::size_t rejected = 0;    ///< commands the driver rejected (as the node did live)
  std::size_t recordedStates = 0;  ///< states in the input bag
  std::size_t compared = 0;    ///< recorded states compared with the re-simulation
  /// Of those, bit-identical: the same bits of every position, of every velocity where the
  /// recording holds them, and the same state hash (which covers the velocities too).
  std::size_t identical = 0;
  std::uint64_t firstMismatch = 0;  ///< step of the first differing state (if any)
  /// The first differing state, named, and how it differs ("recorded state 52 of 105 (step 51,
  /// stamp ... s): positions differ by up to 1 m (vertex 80)"); empty when none differs.
  std::string firstDifference;
  double maxPositionDifference = 0.0;  ///< m: the farthest a vertex is from where it was recorded
  double maxVelocityDifference = 0.0;  ///< m/s: likewise, where velocities were recorded
  std::string finalHash;
  EnergyReport energy;
  BalanceJudgement balance;  ///< of `energy` (Simulator::balance)
  EdgeStretch stretch;  ///< of the final state
  std::vector<std::string> warnings;
  /// Why the simulation failed (a step that could not be taken), empty when it ran to the end.
  /// The report then describes the run up to the failure, and no bag is written.
  std::string failure;
};

/// Runs into `outBag`, through a temporary file renamed at the end (RunWriter). `inBag` may be
/// empty. An error is bad input: an unreadable or inconsistent bag, a bad scene, an output that
/// is one of the inputs, a run too long, a recorded state that is damaged (not finite, not one
/// position per vertex: StateReader, stateDamage()); a simulation that fails is a report with
/// `failure`.
Expected<BagRunReport> runToBag(const std::string& inBag, const std::string& outBag,
                                const BagRunOptions& options);

/// The timeline of a replay of `run` (null: a run without a recording, from ROS time 0): the
/// recorded states' (runTimeline()), else from the start of the bag. An error names a first state
/// that fits no run started within the recording at the step `dt`.
Expected<Timeline> replayTimeline(const RecordedRun* run, double dt);

/// A recorded run replayed by whoever steps the SimulationDriver: fem_cloth_sim --commands
/// (runToBag) and fem_cloth_node's replay_mode drive (the node reads the bag itself and steps in
/// lock-step with it). Both submit each recorded command just before the step it takes effect
/// before, as the node had received it by then (judged against the scene as it is at that
/// moment), take the same number of steps and compare the same recorded states: so the node's
/// states are fem_cloth_sim's, bit for bit.
class RunReplay {
 public:
  /// `run` may be null (a scene run alone). `duration` (s): 0 for the default, up to the last
  /// recorded state, or the last command + 1 s, or the scene's duration. Counts the commands and
  /// recorded states in `report`. Errors: a recorded state that is damaged (stateDamage(), for a
  /// mesh of `vertices` vertices), a run too long (as runToBag's).
  static Expected<std::unique_ptr<RunReplay>> open(const RecordedRun* run, const std::string& node, const Scene& scene,
                                                   const Timeline& timeline, double duration, std::size_t vertices,
                                                   BagRunReport& report);
  ~RunReplay();
  /// The steps the replay takes from step 0.
  std::uint64_t steps() const;
  /// step -> state hash of every recorded state.
  const std::map<std::uint64_t, std::string>& recordedStates() const;
  /// Before each step: submits the commands due before it; `rejected` hears of each the driver
  /// refuses (the node refused it live too: the recording holds what it applied).
  void submitDue(SimulationDriver& driver, const std::function<void(const Command&, const Status&)>& rejected);
  /// Before the first step and after each: compares the recorded states of the driver's step
  /// with its state, counting in `report` (compared, identical, the first difference). Call it
  /// for every step, in order.
  Status compare(const SimulationDriver& driver, BagRunReport& report);

 private:
  RunReplay();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// A recorded run for the accuracy report (io/recording.h): its commands and tf frames drive a
/// simulation through the node's SimulationDriver. Errors as readRun's.
Expected<std::shared_ptr<const Recording>> readRecording(const std::string& path,
                                                         const std::string& node = "/fem_cloth_node");

}  // namespace fem_cloth
