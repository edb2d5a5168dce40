// Offline re-simulation into a bag, without a ROS master (fem_cloth_sim --commands / --out *.bag).
//
// With a recorded run, its scene (or another), its commands and its tf frames are fed to the same
// SimulationDriver the node uses, at full speed, so every command takes effect at the step it
// did live; each recorded state hash is checked against the re-simulation. Without one, the
// scene simply runs and is written out.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "fem_cloth/core/metrics.h"
#include "fem_cloth/core/simulator.h"
#include "fem_cloth/io/recording.h"
#include "fem_cloth/ros/bag_io.h"

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
  std::uint64_t steps = 0;
  double simulated = 0.0;  ///< s
  double wall = 0.0;       ///< s
  std::array<std::size_t, kCommandTopics> commands{};  ///< replayed, per command topic
  bool exactCommands = false;  ///< replayed the applied-command stream
  std::size_t rejected = 0;    ///< commands the driver rejected (as the node did live)
  std::size_t compared = 0;    ///< recorded states compared with the re-simulation
  std::size_t identical = 0;   ///< of those, bit-identical (same state hash)
  std::uint64_t firstMismatch = 0;  ///< step of the first differing state (if any)
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
/// is one of the inputs, a run too long; a simulation that fails is a report with `failure`.
Expected<BagRunReport> runToBag(const std::string& inBag, const std::string& outBag,
                                const BagRunOptions& options);

/// A recorded run for the accuracy report (io/recording.h): its commands and tf frames drive a
/// simulation through the node's SimulationDriver. Errors as readRun's.
Expected<std::shared_ptr<const Recording>> readRecording(const std::string& path,
                                                         const std::string& node = "/fem_cloth_node");

}  // namespace fem_cloth
