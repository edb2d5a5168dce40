// The node's services for live changes (docs/node.md, Live changes): ~set, ~add_obstacle,
// ~remove_obstacle, ~move_obstacle and ~grasp_nearest. Each checks its request at once against
// the scene as the applied changes have left it (the reply names what is wrong, and nothing is
// queued), then hands it to the node's CommandInbox as the matching command (SetCommand,
// ObstacleCommand, GraspCommand) with a ticket, and answers with the outcome of applying it:
// the run loop applies it at the next step boundary (a paused node at once), publishes it on
// ~applied_set, ~applied_obstacle or ~applied_grasp (a recording replays it from there like any
// command), and hands its outcome back here (answer()). A request the run loop refuses (a frame
// tf does not know, no vertex within the radius, an obstacle in the cloth) is answered with
// success false and the reason; so is one the node drops (it paused itself, a ~reset).
#pragma once

#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <yaml-cpp/yaml.h>

#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "fem_cloth/GraspNearest.h"
#include "fem_cloth/ObstacleChange.h"
#include "fem_cloth/Set.h"
#include "fem_cloth/ros/command_queue.h"

namespace fem_cloth {

class LiveServices {
 public:
  /// Serves on `node`'s namespace from a queue and threads of its own (a call waits for the run
  /// loop without holding up the node's other callbacks). `document`: the scene document the
  /// node runs.
  LiveServices(const ros::NodeHandle& node, CommandInbox& inbox, const YAML::Node& document);
  ~LiveServices();

  /// The run loop, for each command it applied (from a service or a topic): the document after
  /// it, which the next request is checked against.
  void applied(const Command& command, const YAML::Node& document);
  /// The run loop: the outcome of the command with `ticket` (an error: why it was not applied),
  /// `command` as applied, in the state of step `step` at simulation time `time` (before the
  /// next step).
  void answer(std::uint64_t ticket, const Status& outcome, const Command& command, std::uint64_t step, double time);

 private:
  struct Outcome {
    Status status;
    std::vector<std::uint32_t> vertices;  // a grasp's
    std::string when;                     // "at step N, t = T s": the state it took effect in
  };
  bool onSet(Set::Request& req, Set::Response& res);
  bool onObstacle(std::uint8_t action, ObstacleChange::Request& req, ObstacleChange::Response& res);
  bool onGraspNearest(GraspNearest::Request& req, GraspNearest::Response& res);
  /// Hands `command` to the inbox and waits for its outcome (an error when the inbox is full).
  Outcome submitAndWait(Command command);
  YAML::Node document() const;

  CommandInbox& inbox_;
  mutable std::mutex mutex_;
  std::condition_variable answered_;
  YAML::Node document_;                      // as the applied changes left it
  std::map<std::uint64_t, Outcome> outcomes_;  // ticket -> outcome, until its caller takes it
  std::uint64_t nextTicket_ = 1;
  bool stopping_ = false;
  ros::CallbackQueue queue_;
  std::unique_ptr<ros::AsyncSpinner> spinner_;
  std::vector<ros::ServiceServer> services_;
};

}  // namespace fem_cloth
