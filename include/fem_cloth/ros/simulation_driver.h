// The simulation as ROS messages see it, without needing a ROS master: commands in (validated,
// scheduled by their stamp, frames resolved through a tf2 buffer), one step at a time, messages
// out. The node (cloth_node.h) feeds it from topics and publishes what it builds; the offline
// bag re-simulation feeds it from a bag. Sharing it is what makes a live run and its offline
// replay apply every command at the same step.
//
// Time: simulation time t (s, from 0) maps to ROS time epoch + t. A command takes effect before
// the first step that starts at or after its stamp (zero stamp: before the next step). Every
// output message is stamped with the simulation time of the state it carries. Stamps are range
// checked (time_checks.h): a stamp no ROS duration can relate to the epoch is refused by name.
#pragma once

#include <geometry_msgs/WrenchStamped.h>
#include <ros/time.h>
#include <shape_msgs/Mesh.h>
#include <tf2/buffer_core.h>
#include <visualization_msgs/Marker.h>
#include <visualization_msgs/MarkerArray.h>

#include <array>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "fem_cloth/ClothEnergy.h"
#include "fem_cloth/ClothState.h"
#include "fem_cloth/ForceCommand.h"
#include "fem_cloth/PinCommand.h"
#include "fem_cloth/PinForces.h"
#include "fem_cloth/StepStats.h"
#include "fem_cloth/core/metrics.h"
#include "fem_cloth/core/scene.h"
#include "fem_cloth/ros/command_queue.h"

namespace fem_cloth {

struct DriverSettings {
  std::string frame = "world";  ///< the simulation frame
  ros::Time epoch;              ///< ROS time of simulation time 0
  /// A frame whose newest transform is older than this (s, in ROS time) is stale: commands
  /// referring to it are rejected, and the pins that follow it stop following and stay put.
  double tfTimeout = 1.0;
  bool publishVelocities = false;
  /// A pin target farther than this (m) from where its vertex is is refused: the pin would move
  /// the vertex there within one step. Checked when a pin command is applied and whenever a
  /// followed frame moves its pins (a frame that jumps loses its followers).
  double maxPinJump = 1.0;
  /// At most this many validated commands wait for their time; more are refused.
  std::size_t maxPendingCommands = 10000;
};

/// 64-bit FNV-1a over the bits of the positions, then the velocities, as 16 hex digits.
std::string stateHash(const VectorX& x, const VectorX& v);

class SimulationDriver {
 public:
  /// tf may be null: then only commands in the simulation frame are accepted.
  SimulationDriver(Simulation simulation, Scene scene, DriverSettings settings,
                   const tf2::BufferCore* tf);

  const Scene& scene() const { return scene_; }
  const DriverSettings& settings() const { return settings_; }
  Simulator& simulator() { return *simulation_.simulator; }
  const Simulator& simulator() const { return *simulation_.simulator; }
  std::uint64_t stepIndex() const { return simulator().state().step; }
  ros::Time stampOf(double simulationTime) const;
  ros::Time now() const { return stampOf(simulator().time()); }
  void setEpoch(const ros::Time& epoch) { settings_.epoch = epoch; }

  /// Validates a command against the mesh, the tf buffer and itself, and queues it. A command
  /// is rejected whole; the message names the problem.
  Status submit(const PinCommand& command);
  Status submit(const ForceCommand& command);
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
  /// where they are, with a warning. The step itself fails as Simulator::step does, or when its
  /// end would map to no ROS time.
  StepReport step();
  /// Back to the initial state; pending commands (counted as discarded) and frame-following pins
  /// are dropped.
  void reset();
  /// Problems met while stepping (a frame no longer available, a command that could not be
  /// applied), since the last call.
  std::vector<std::string> takeWarnings();
  /// The commands applied since the last call, each stamped with the simulation time (as ROS
  /// time) of the step before which it took effect: replaying exactly these reproduces the run.
  std::vector<PinCommand> takeAppliedPins();
  std::vector<ForceCommand> takeAppliedForces();

  // --- Messages -------------------------------------------------------------------------------
  shape_msgs::Mesh meshMessage() const;
  ClothState stateMessage() const;
  ClothEnergy energyMessage();
  StepStats statsMessage(const StepReport& report, double wallTime, double realTimeFactor) const;
  PinForces pinForcesMessage() const;
  /// One wrench per grasp frame (the sum over the pins that follow it, expressed in that frame,
  /// torque about its origin) and one in the simulation frame for pins fixed there.
  std::vector<geometry_msgs::WrenchStamped> pinWrenchMessages() const;
  /// The scene's obstacles as RViz markers at their current poses (empty without obstacles): a
  /// plane as a thin square slab of side kPlaneMarkerSide whose top is the plane, a box, a
  /// sphere, a capsule as a cylinder and two spheres; namespace "obstacles", ids 3k to 3k+2.
  visualization_msgs::MarkerArray obstacleMarkers() const;
  /// Per obstacle (in scene order): the force the cloth exerts on it in the simulation frame,
  /// torque about the origin of its shape (a sphere's or box's centre, a plane's point).
  std::vector<geometry_msgs::WrenchStamped> obstacleWrenchMessages() const;
  /// Names of the obstacles (scene order), as they appear in topic names.
  std::vector<std::string> obstacleNames() const;

 private:
  struct Follow {
    std::string frame;
    Eigen::Vector3d local;  // target in that frame
  };

  Status checkFrame(const std::string& frame, const ros::Time& stamp) const;
  bool isSimulationFrame(const std::string& frame) const;
  /// `frame` -> simulation frame at `at`; when tf cannot interpolate there, the nearest
  /// transform within tf_timeout, and `inexact` (if given) says which one was used.
  std::optional<Eigen::Isometry3d> transform(const std::string& frame, const ros::Time& at,
                                             std::string* why, std::string* inexact = nullptr) const;
  /// True when tf can interpolate `frame` at `at`, or when waiting cannot help: `at` is not
  /// later than the newest transform received (it precedes the frame's first transform, or
  /// falls in a gap), so the transform for it will never arrive.
  bool knownOrNeverWillBe(const std::string& frame, const ros::Time& at) const;
  /// The simulation time a stamp stands for (-1 for a zero stamp: the next step), or an error
  /// naming header.stamp when no ROS duration relates it to the epoch.
  Expected<double> commandTime(const ros::Time& stamp) const;
  /// submit() for either kind: counts, checks the stamp, then `check`, then queues.
  template <class C>
  Status submitCommand(const C& command);
  Status check(const PinCommand& command) const;
  Status check(const ForceCommand& command) const;
  /// (frame, simulation time) of every transform the next step needs.
  std::vector<std::pair<std::string, double>> neededTransforms() const;
  /// Error naming the first vertex whose target is farther than maxPinJump from it.
  Status checkJumps(const std::vector<Index>& vertices,
                    const std::vector<Eigen::Vector3d>& targets) const;
  Status apply(const PinCommand& command);
  Status apply(const ForceCommand& command);
  void followFrames(double endTime);
  /// Poses of the frames obstacles follow at the start and end of the step from `time`.
  void followObstacleFrames(double time, double endTime);

  Simulation simulation_;
  Scene scene_;
  DriverSettings settings_;
  const tf2::BufferCore* tf_;
  CommandQueue pending_;
  std::array<CommandCounts, kCommandTopics> counts_{};  // pending is pending_'s
  std::map<Index, Follow> follow_;
  std::map<std::size_t, Eigen::Isometry3d> obstacleFrame_;  // last known pose of a followed frame
  std::vector<std::string> warnings_;
  std::vector<PinCommand> appliedPins_;
  std::vector<ForceCommand> appliedForces_;
};

}  // namespace fem_cloth
