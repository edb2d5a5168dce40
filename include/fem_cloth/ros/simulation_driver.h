// The simulation as ROS commands drive it, without needing a ROS master: commands in (validated,
// scheduled by their stamp in a CommandQueue, frames resolved by a FrameResolver, pins kept by a
// PinSet), one step at a time; what it holds goes out through the free conversions of
// conversions.h. The node (cloth_node.h) feeds it from topics and publishes what it builds; the offline
// bag re-simulation feeds it from a bag. Sharing it is what makes a live run and its offline
// replay apply every command at the same step.
//
// Time: simulation time t (s, from 0) maps to ROS time through a Timeline (timeline.h): epoch + t
// until a pause starts a new segment. A command takes effect before the first step that starts at
// or after the simulation time its stamp stands for (zero stamp: before the next step). Every
// output message is stamped with the ROS time of the state it carries. Stamps are range checked
// (time_checks.h): a stamp no ROS duration can relate to the timeline is refused by name.
#pragma once

#include <ros/time.h>
#include <tf2/buffer_core.h>

#include <array>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "fem_cloth/core/pin_set.h"
#include "fem_cloth/core/scene.h"
#include "fem_cloth/io/live_change.h"
#include "fem_cloth/ros/command_queue.h"
#include "fem_cloth/ros/conversions.h"
#include "fem_cloth/ros/frame_resolver.h"
#include "fem_cloth/ros/timeline.h"

namespace fem_cloth {

struct DriverSettings {
  std::string frame = "world";  ///< the simulation frame
  ros::Time epoch;              ///< ROS time of simulation time 0 (the timeline's first segment)
  /// A frame whose newest transform is older than this (s, in ROS time) is stale: commands
  /// referring to it are rejected, and the pins that follow it stop following and stay put.
  double tfTimeout = 1.0;
  /// A pin target farther than this (m) from where its vertex is is refused: the pin would move
  /// the vertex there within one step. Checked when a pin command is applied and whenever a
  /// followed frame moves its pins (a frame that jumps loses its followers).
  double maxPinJump = 1.0;
  /// At most this many validated commands wait for their time; more are refused.
  std::size_t maxPendingCommands = 10000;
};

class SimulationDriver {
 public:
  /// tf may be null: then only commands in the simulation frame are accepted. `document` is the
  /// scene document the simulation was built from; without it, live changes (~set, obstacle
  /// commands) are refused.
  SimulationDriver(Simulation simulation, DriverSettings settings, const tf2::BufferCore* tf,
                   YAML::Node document = YAML::Node());

  const DriverSettings& settings() const { return settings_; }
  /// The scene document as live changes have left it (null without one).
  const YAML::Node& document() const { return document_; }
  Simulator& simulator() { return *simulation_.simulator; }
  const Simulator& simulator() const { return *simulation_.simulator; }
  std::uint64_t stepIndex() const { return simulator().state().step; }
  ros::Time stampOf(double simulationTime) const;
  ros::Time now() const { return stampOf(simulator().time()); }
  /// A header stamped now, in the simulation frame: what every output message carries.
  std_msgs::Header header() const { return fem_cloth::header(now(), settings_.frame); }
  /// One segment from `epoch` on (before the first step, or after reset()).
  void setEpoch(const ros::Time& epoch) { setTimeline(Timeline(epoch)); }
  const Timeline& timeline() const { return timeline_; }
  /// A whole timeline, as rebuilt from a recording (runTimeline(), bag_io.h).
  void setTimeline(Timeline timeline);
  /// A new segment from the current state on at ROS time `stamp` (Timeline::start()): after a
  /// pause. Pending commands are timed anew.
  void startSegment(const ros::Time& stamp);

  /// Validates a command against the mesh, the tf buffer and itself, and queues it. A command
  /// is rejected whole; the message names the problem. A command with a `ticket` (not 0) has its
  /// outcome, once it is applied or fails when due, listed by takeOutcomes().
  Status submit(const Command& command, std::uint64_t ticket = 0);
  std::size_t pendingCommands() const { return pending_.size(); }
  /// What became of the commands of a topic since construction (submitted = received; reset()
  /// does not clear the counts).
  CommandCounts commandCounts(CommandTopic topic) const;

  /// True when every transform the next step needs is known at exactly the time it is needed:
  /// the frames of the commands due at the start of the step, and the frames followed by pins
  /// at its end. Otherwise `missing` names one. Stepping anyway falls back to a frame's newest
  /// transform, which a replay of the run may not see the same way: the node waits for this
  /// (up to tf_timeout) before each step.
  bool transformsReady(std::string* missing) const;
  /// The frames that transformsReady() waits for, each once.
  std::vector<std::string> framesNotReady() const;

  /// Applies the commands that are due, moves frame-following pins to where their frames are at
  /// the end of the step, and advances one step. Commands that fail when applied are reported
  /// through takeWarnings() (and counted as rejected). Pins whose frame has gone stale (its newest
  /// transform older than tf_timeout) or jumps farther than maxPinJump stop following it and stay
  /// where they are, with a warning. A step the simulator flags (a pin jump, StepReport::warning)
  /// is a warning too. The step itself fails as Simulator::step does, or when its end would map
  /// to no ROS time.
  StepReport step();
  /// Applies the ticketed commands due now (a service's request, whose caller waits) without
  /// stepping: a paused node. They take effect before the next step either way; the others
  /// (from the topics) still wait for it.
  void applyTicketedNow();
  /// Whether a ticketed command is due now (applyTicketedNow() would apply or refuse it).
  bool ticketedDueNow() const;
  /// What became of the ticketed commands applied or failed since the last call.
  struct Outcome {
    std::uint64_t ticket = 0;
    Status status;    ///< applied, or why not
    Command command;  ///< as applied (GraspCommand: with the vertices it pinned)
  };
  std::vector<Outcome> takeOutcomes();
  /// Drops the ticketed commands still pending (counted as discarded); returns their tickets.
  std::vector<std::uint64_t> withdrawTicketed();
  /// Back to the initial state; pending commands (counted as discarded) and frame-following pins
  /// are dropped, and the timeline keeps its first segment only.
  void reset();
  /// The deepest the cloth's surface reached into a box between its vertices since the start or
  /// the last reset (StepReport::boxDepth, m), where, and in which step; depth 0: it did not.
  struct BoxDepth {
    double depth = 0.0;
    std::string where;
    std::uint64_t step = 0;
  };
  const BoxDepth& deepestIntoBox() const { return deepestIntoBox_; }
  /// Problems met while stepping (a frame no longer available, a command that could not be
  /// applied, a pin jump), since the last call.
  std::vector<std::string> takeWarnings();
  /// The commands applied since the last call, in the order they took effect, each stamped with
  /// the simulation time (as ROS time) of the step before which it took effect: replaying
  /// exactly these reproduces the run.
  std::vector<Command> takeApplied();
  /// Those of one type (the others are kept for takeApplied()).
  template <class C>
  std::vector<C> takeApplied();
  std::vector<PinCommand> takeAppliedPins() { return takeApplied<PinCommand>(); }
  std::vector<ForceCommand> takeAppliedForces() { return takeApplied<ForceCommand>(); }

  // --- What the messages are made of (conversions.h makes them) ---------------------------------
  /// The pose of a frame now (the simulation frame's is the identity).
  FramePose framePose(const std::string& frame) const { return frames_.pose(frame, now()); }
  const FrameResolver& frames() const { return frames_; }
  const PinSet& pins() const { return pinSet_; }
  /// One wrench per grasp frame (the pins that follow it, expressed in that frame, torque about
  /// its origin) and one in the simulation frame for pins fixed there, from `reactions`
  /// (Simulator::pinReactions(), computed once by the caller for every message that needs it).
  std::vector<GraspWrench> graspWrenches(const VectorX& reactions) const;
  /// Names of the obstacles (scene order), as they appear in topic names.
  std::vector<std::string> obstacleNames() const;

 private:
  /// The simulation time a stamp stands for (-1 for a zero stamp: the next step), or an error
  /// naming header.stamp when no ROS duration relates it to the timeline.
  Expected<double> commandTime(const ros::Time& stamp) const;
  Status checkFrame(const std::string& frame, const ros::Time& stamp) const;
  /// Refuses a grasp frame whose wrench topic (graspWrenchTopic()) is that of another frame
  /// pins follow, or of the simulation frame.
  Status checkWrenchTopic(const std::string& frame) const;
  // Per command type (simulation_driver.cpp): validation when submitted, the effect when due,
  // and the simulation times (0: the step's start, 1: its end) whose transforms it needs.
  template <class C>
  Status check(const C& command) const;
  template <class C>
  Status apply(C& command);  // may fill in what it did (GraspCommand: the vertices)
  template <class C>
  std::vector<int> transformTimes(const C& command) const;
  /// (frame, simulation time) of every transform the next step needs.
  std::vector<std::pair<std::string, double>> neededTransforms() const;
  void applyDue(double t, bool ticketedOnly = false);
  /// The simulation rebuilt for a changed scene (core/live_change.h), continuing from now.
  Status changeScene(Expected<LiveChange> change);
  /// The document to change, or an error when the driver has none.
  Status needsDocument() const;
  /// Pending commands timed anew after the timeline changed.
  void retimePending();
  /// Poses of the frames obstacles follow at the start and end of the step from `time`.
  void followObstacleFrames(double time, double endTime);

  Simulation simulation_;
  DriverSettings settings_;
  Timeline timeline_;
  YAML::Node document_;
  FrameResolver frames_;
  CommandQueue pending_;
  std::array<CommandCounts, kCommandTopics> counts_{};  // pending is pending_'s
  PinSet pinSet_;
  std::map<std::size_t, Eigen::Isometry3d> obstacleFrame_;  // last known pose of a followed frame
  std::vector<std::string> warnings_;
  std::vector<Command> applied_;
  std::vector<Outcome> outcomes_;
  BoxDepth deepestIntoBox_;
};

/// The node's wrench topic of the pins that follow `frame`: grasp/<frame>/wrench, with the
/// characters a ROS name cannot hold as '_' (frames that differ only there would share it: the
/// driver refuses the second, SimulationDriver::check()).
std::string graspWrenchTopic(const std::string& frame);

/// Why `name` cannot name an obstacle (it names the topic ~obstacles/<name>/wrench): not a valid
/// ROS name, or with a '/'.
Status obstacleNameProblem(const std::string& name);
/// What is wrong with an obstacle command on `document` (a scene document): an unknown action, a
/// bad name to add, a change the scene refuses. The ~add/remove/move_obstacle services answer
/// with it at once; the driver checks the same when the command comes.
Status obstacleCommandProblem(const YAML::Node& document, const ObstacleCommand& command);
/// What is wrong with a grasp's point and radius (its frame is the driver's to check): the
/// ~grasp_nearest service answers with it at once.
Status graspShapeProblem(const GraspCommand& command);

/// The statistics of the step just taken (wall time and real-time factor as measured by the
/// caller), with the command counts `counts` gives (none: the driver's; the node adds its inbox's).
StepStats statsMessage(const SimulationDriver& driver, const StepReport& report, double wallTime,
                       double realTimeFactor,
                       const std::function<CommandCounts(CommandTopic)>& counts = nullptr);
/// The /diagnostics entries for the deepest reach into a box (key, value): its depth in mm, where
/// and in which step; "0" and empty when the surface did not reach into a box.
std::vector<std::pair<std::string, std::string>> boxDepthDiagnostics(const SimulationDriver::BoxDepth& deepest);
/// The /diagnostics message for it (a warning, as fem_cloth_sim's), empty when there is none.
std::string boxDepthWarning(const SimulationDriver::BoxDepth& deepest);
/// Sets `msg.commands` (one entry per command topic, in CommandTopic order) and the older
/// pin_commands and force_commands from `counts`.
void setCommandStats(StepStats& msg, const std::function<CommandCounts(CommandTopic)>& counts);

template <class C>
std::vector<C> SimulationDriver::takeApplied() {
  std::vector<C> out;
  std::vector<Command> rest;
  for (Command& c : applied_) {
    if (C* mine = std::get_if<C>(&c)) {
      out.push_back(std::move(*mine));
    } else {
      rest.push_back(std::move(c));
    }
  }
  applied_.swap(rest);
  return out;
}

}  // namespace fem_cloth
