// Runs in bags: what a recording of fem_cloth_node holds, read back for re-simulation, and
// written by the offline re-simulation. No ROS master is needed.
//
// A recording (launch/record.launch) holds, for a node named NS:
//   NS/scene          std_msgs/String (latched)  the scene YAML the node ran
//   NS/applied_<t>    the commands of each command topic t (command_queue.h: pin, force, ...)
//                     as applied, stamped with the step's time
//   NS/<t>            the commands as sent (used when the applied ones are missing)
//   NS/mesh, NS/state, NS/energy, NS/stats, NS/pin_forces, NS/pin_wrench, /tf, /tf_static
#pragma once

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <shape_msgs/Mesh.h>
#include <tf2/buffer_core.h>
#include <yaml-cpp/yaml.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fem_cloth/ClothState.h"
#include "fem_cloth/core/expected.h"
#include "fem_cloth/core/mesh.h"
#include "fem_cloth/ros/command_queue.h"
#include "fem_cloth/ros/timeline.h"

namespace fem_cloth {

/// The most a recording may span (s, 31 years): every stamp readRun accepts lies within it of the
/// start of the recording, so differences of stamps stay within what ros::Duration holds (2^31 s).
constexpr double kMaxRecordingSpan = 1e9;

/// The topic names of a node's run.
struct RunTopics {
  explicit RunTopics(const std::string& node = "/fem_cloth_node");
  std::string ns;  ///< the node's name, with a leading '/'
  std::string scene, mesh, state, energy, stats, pinForces, pinWrench, pin, force, appliedPin,
      appliedForce;
  /// A command topic as sent (NS/pin) and as applied (NS/applied_pin).
  std::string sent(CommandTopic topic) const;
  std::string applied(CommandTopic topic) const;
};

struct RecordedState {
  std::uint64_t step = 0;
  ros::Time stamp;
  std::string hash;
};

/// A run read back from a bag.
struct RecordedRun {
  std::string path;
  std::string sceneYaml;  ///< empty when the bag holds no scene
  std::string frame;      ///< the simulation frame of the recorded states (empty if none)
  std::optional<shape_msgs::Mesh> mesh;
  std::vector<RecordedState> states;
  /// The commands to replay, topic after topic (Command's order), each topic's in bag order: the
  /// applied ones when the bag has them (exact), else the ones sent, a zero stamp replaced by
  /// the time the message was recorded.
  std::vector<Command> commands;
  bool exactCommands = false;  ///< the commands came from applied_pin / applied_force
  std::shared_ptr<tf2::BufferCore> tf;  ///< every /tf and /tf_static message of the bag
  std::vector<std::string> warnings;     ///< what was left out (transforms tf refused)
  ros::Time begin, end;  ///< the bag's time range
};

/// Reads a run. Errors name the problem: a missing or unreadable file, an empty, truncated or
/// otherwise damaged bag, a known topic with the wrong message type, a stamp farther than
/// kMaxRecordingSpan from the start of the recording, a reset of the node (the states' step
/// going back), which no replay can reproduce.
Expected<RecordedRun> readRun(const std::string& path, const std::string& node = "/fem_cloth_node");

/// The scene document a run holds (the one way to read it: the node's ~replay_bag, fem_cloth_sim
/// --commands and the report). The error names the bag and says what to do instead.
Expected<YAML::Node> storedScene(const RecordedRun& run, const std::string& node = "/fem_cloth_node");

/// The ROS time of simulation time 0 of a recorded run (from its states and the step size); none
/// without states, or when the first state's step x dt does not fit before its stamp.
std::optional<ros::Time> runEpoch(const RecordedRun& run, double dt);

/// The timeline (timeline.h) of a recorded run: from runEpoch() on, a new segment wherever a
/// state's stamp leaves the one before by more than kSegmentTolerance (a pause); the node
/// publishes the state a segment starts from with its new stamp before stepping on. None when
/// runEpoch() has none.
std::optional<Timeline> runTimeline(const RecordedRun& run, double dt);
/// s: stamps of one segment fit it to the nanosecond; a pause is at least a service call long.
constexpr double kSegmentTolerance = 1e-6;

/// The recorded states of a run (NS/state), read one after the other in bag order: a replay
/// checks and compares them as it goes, without holding them all.
class StateReader {
 public:
  /// Errors as readRun's for a bag that cannot be opened.
  static Expected<std::unique_ptr<StateReader>> open(const std::string& path,
                                                     const std::string& node = "/fem_cloth_node");
  /// Reads the next state into `state`: true when there was one, false after the last; an error
  /// names a message that cannot be read.
  Expected<bool> next(ClothState& state);
  std::size_t count() const { return count_; }  ///< states in the bag
  std::size_t read() const { return read_; }    ///< states read so far: the last one's place, from 1
  /// The last state read, named for messages: "recorded state K of N (step S, stamp T s)".
  std::string name(const ClothState& state) const;

 private:
  StateReader() = default;
  std::string path_;
  rosbag::Bag bag_;
  std::unique_ptr<rosbag::View> view_;
  rosbag::View::iterator it_;
  std::size_t count_ = 0, read_ = 0;
};

/// Why `state` cannot be a state of a cloth of `vertices` vertices (empty when it can): not one
/// position per vertex, a position that is not finite, velocities recorded but not one per
/// vertex, or one not finite.
std::string stateDamage(const ClothState& state, std::size_t vertices);

/// Checks that a mesh stored in a bag is the scene's mesh (same triangles, same rest positions).
Status checkMeshMatches(const shape_msgs::Mesh& recorded, const Mesh& scene);

/// Writes a bag through a temporary file next to it (createTemporaryNextTo) that takes the
/// final name only in close(): a run that fails or is killed leaves no output that looks valid.
/// An empty path writes nothing (a run only verified).
class RunWriter {
 public:
  static Expected<std::unique_ptr<RunWriter>> open(const std::string& path);
  ~RunWriter();
  template <class M>
  void write(const std::string& topic, const ros::Time& time, const M& message) {
    if (!path_.empty()) bag_.write(topic, time, message);
  }
  /// Copies a message of another bag as it was recorded: topic, time and connection header (a
  /// latched /tf_static stays latched for rosbag play).
  void copy(const rosbag::MessageInstance& message) {
    if (!path_.empty()) bag_.write(message.getTopic(), message.getTime(), message, message.getConnectionHeader());
  }
  bool writes() const { return !path_.empty(); }
  /// Closes and renames the bag into place.
  Status close();

 private:
  RunWriter(std::string path, std::string temporary)
      : path_(std::move(path)), temporary_(std::move(temporary)) {}
  std::string path_, temporary_;
  rosbag::Bag bag_;
  bool closed_ = false;
};

}  // namespace fem_cloth
