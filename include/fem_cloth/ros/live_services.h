// The node's services for live changes (docs/node.md, Live changes): ~set, ~add_obstacle,
// ~remove_obstacle, ~move_obstacle and ~grasp_nearest. Each checks its request at once against
// the scene as the applied changes have left it (the reply names what is wrong, and nothing is
// queued), then hands it to the node's CommandInbox as the matching command (SetCommand,
// ObstacleCommand, GraspCommand): the run loop applies it at the next step boundary, publishes
// it on ~applied_set, ~applied_obstacle or ~applied_grasp, and a recording replays it from
// there like any command. ~grasp_nearest waits (up to a second) for its grasp to be applied, to
// answer with the vertices it pinned.
#pragma once

#include <ros/ros.h>
#include <yaml-cpp/yaml.h>

#include <condition_variable>
#include <cstdint>
#include <map>
#include <mutex>
#include <vector>

#include "fem_cloth/GraspNearest.h"
#include "fem_cloth/ObstacleChange.h"
#include "fem_cloth/Set.h"
#include "fem_cloth/ros/command_queue.h"

namespace fem_cloth {

class LiveServices {
 public:
  /// `quick` serves ~set and the obstacle services; `blocking` (a queue of its own) serves
  /// ~grasp_nearest, which waits for the run loop. `document`: the scene document the node runs.
  LiveServices(ros::NodeHandle quick, ros::NodeHandle blocking, CommandInbox& inbox, const YAML::Node& document);

  /// The run loop, for each command it applied: the document after it (a live change), and the
  /// vertices a grasp pinned, for the caller waiting on ~grasp_nearest.
  void applied(const Command& command, const YAML::Node& document);

 private:
  bool onSet(Set::Request& req, Set::Response& res);
  bool onObstacle(std::uint8_t action, ObstacleChange::Request& req, ObstacleChange::Response& res);
  bool onGraspNearest(GraspNearest::Request& req, GraspNearest::Response& res);
  /// The inbox's refusal, as a service answer (false: refused).
  bool queue(Command command, std::string* message);
  YAML::Node document() const;

  CommandInbox& inbox_;
  mutable std::mutex mutex_;
  std::condition_variable graspDone_;
  YAML::Node document_;                                       // as the applied changes left it
  std::map<std::uint32_t, std::vector<std::uint32_t>> grasped_;  // grasp id -> vertices
  std::uint32_t nextGrasp_ = 1;
  std::vector<ros::ServiceServer> services_;
};

}  // namespace fem_cloth
