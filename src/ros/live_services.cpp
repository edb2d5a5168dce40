#include "fem_cloth/ros/live_services.h"

#include <boost/function.hpp>

#include <chrono>

#include "fem_cloth/io/live_change.h"
#include "fem_cloth/ros/simulation_driver.h"

namespace fem_cloth {

LiveServices::LiveServices(ros::NodeHandle quick, ros::NodeHandle blocking, CommandInbox& inbox,
                           const YAML::Node& document)
    : inbox_(inbox), document_(YAML::Clone(document)) {
  services_.push_back(quick.advertiseService("set", &LiveServices::onSet, this));
  const std::vector<std::pair<const char*, std::uint8_t>> obstacles = {
      {"add_obstacle", ObstacleCommand::ADD}, {"remove_obstacle", ObstacleCommand::REMOVE}, {"move_obstacle", ObstacleCommand::MOVE}};
  for (const auto& [name, action] : obstacles) {
    const std::uint8_t a = action;
    services_.push_back(quick.advertiseService<ObstacleChange::Request, ObstacleChange::Response>(
        name, boost::function<bool(ObstacleChange::Request&, ObstacleChange::Response&)>(
                  [this, a](ObstacleChange::Request& req, ObstacleChange::Response& res) { return onObstacle(a, req, res); })));
  }
  services_.push_back(blocking.advertiseService("grasp_nearest", &LiveServices::onGraspNearest, this));
}

YAML::Node LiveServices::document() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return YAML::Clone(document_);
}

bool LiveServices::queue(Command command, std::string* message) {
  if (inbox_.push(std::move(command))) return true;
  *message = "refused: " + std::to_string(inbox_.capacity()) +
             " commands are already waiting to be checked (max_pending_commands)";
  return false;
}

bool LiveServices::onSet(Set::Request& req, Set::Response& res) {
  const Expected<LiveChange> change = applyLiveChange(document(), req.pairs);
  if (!change) {
    inbox_.refuse(topicOf<SetCommand>());
    res.success = false;
    res.message = "~set refused, nothing changed: " + change.error();
    return true;
  }
  SetCommand c;
  c.pairs = req.pairs;
  res.success = queue(c, &res.message);
  if (res.success) res.message = "applies before the next step (published on ~applied_set)";
  return true;
}

bool LiveServices::onObstacle(std::uint8_t action, ObstacleChange::Request& req, ObstacleChange::Response& res) {
  ObstacleCommand c;
  c.action = action;
  c.name = req.name;
  c.entry = req.entry;
  // The driver's own check, on the document as the applied changes have left it.
  if (Status s = obstacleCommandProblem(document(), c); !s) {
    inbox_.refuse(topicOf<ObstacleCommand>());
    res.success = false;
    res.message = "refused, nothing changed: " + s.error();
    return true;
  }
  res.success = queue(c, &res.message);
  if (res.success) res.message = "applies before the next step (published on ~applied_obstacle)";
  return true;
}

bool LiveServices::onGraspNearest(GraspNearest::Request& req, GraspNearest::Response& res) {
  GraspCommand c;
  c.header.frame_id = req.frame_id;
  c.point = req.point;
  c.radius = req.radius;
  if (Status s = graspShapeProblem(c); !s) {
    inbox_.refuse(topicOf<GraspCommand>());
    res.success = false;
    res.message = s.error();
    return true;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    c.header.seq = nextGrasp_++;
  }
  const std::uint32_t id = c.header.seq;
  if (!queue(c, &res.message)) {
    res.success = false;
    return true;
  }
  // Answered with the vertices once the run loop has applied it; a paused node applies it at
  // its next step, after this answer.
  std::unique_lock<std::mutex> lock(mutex_);
  const bool done = graspDone_.wait_for(lock, std::chrono::seconds(1), [&] { return grasped_.count(id) > 0; });
  res.success = true;
  if (done) {
    res.vertices = grasped_[id];
    grasped_.erase(id);
    res.message = "pinned " + std::to_string(res.vertices.size()) + " vertices";
  } else {
    res.message = "queued: applies before the next step (the vertices will be on ~applied_grasp)";
  }
  return true;
}

void LiveServices::applied(const Command& command, const YAML::Node& document) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (const GraspCommand* g = std::get_if<GraspCommand>(&command)) {
    grasped_[g->header.seq] = g->vertices;
    if (grasped_.size() > 1000) grasped_.erase(grasped_.begin());  // answers nobody waited for
    graspDone_.notify_all();
  } else if (std::holds_alternative<SetCommand>(command) || std::holds_alternative<ObstacleCommand>(command)) {
    document_ = YAML::Clone(document);
  }
}

}  // namespace fem_cloth
