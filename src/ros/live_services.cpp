#include "fem_cloth/ros/live_services.h"

#include <boost/function.hpp>

#include <chrono>

#include "fem_cloth/io/live_change.h"
#include "fem_cloth/ros/simulation_driver.h"

namespace fem_cloth {

namespace {
// Calls that may wait at once for the run loop; more wait in the queue for a free thread.
constexpr std::uint32_t kServiceThreads = 4;
}  // namespace

LiveServices::LiveServices(const ros::NodeHandle& node, CommandInbox& inbox, const YAML::Node& document)
    : inbox_(inbox), document_(YAML::Clone(document)) {
  ros::NodeHandle nh(node);
  nh.setCallbackQueue(&queue_);
  services_.push_back(nh.advertiseService("set", &LiveServices::onSet, this));
  const std::vector<std::pair<const char*, std::uint8_t>> obstacles = {
      {"add_obstacle", ObstacleCommand::ADD}, {"remove_obstacle", ObstacleCommand::REMOVE}, {"move_obstacle", ObstacleCommand::MOVE}};
  for (const auto& [name, action] : obstacles) {
    const std::uint8_t a = action;
    services_.push_back(nh.advertiseService<ObstacleChange::Request, ObstacleChange::Response>(
        name, boost::function<bool(ObstacleChange::Request&, ObstacleChange::Response&)>(
                  [this, a](ObstacleChange::Request& req, ObstacleChange::Response& res) { return onObstacle(a, req, res); })));
  }
  services_.push_back(nh.advertiseService("grasp_nearest", &LiveServices::onGraspNearest, this));
  spinner_ = std::make_unique<ros::AsyncSpinner>(kServiceThreads, &queue_);
  spinner_->start();
}

LiveServices::~LiveServices() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;  // the calls waiting answer, so that the spinner's threads end
  }
  answered_.notify_all();
  for (ros::ServiceServer& s : services_) s.shutdown();
  spinner_->stop();
}

YAML::Node LiveServices::document() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return YAML::Clone(document_);
}

LiveServices::Outcome LiveServices::submitAndWait(Command command) {
  std::uint64_t ticket = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ticket = nextTicket_++;
  }
  if (!inbox_.push(std::move(command), ticket)) {
    return Outcome{Error{"refused: " + std::to_string(inbox_.capacity()) +
                         " commands are already waiting to be checked (max_pending_commands)"},
                   {}, ""};
  }
  // The run loop answers every ticket it takes: applied, refused, or dropped (a self-pause, a
  // ~reset). Only a node shutting down leaves a call without one.
  std::unique_lock<std::mutex> lock(mutex_);
  while (outcomes_.count(ticket) == 0) {
    if (stopping_ || !ros::ok()) return Outcome{Error{"the node is shutting down: not applied"}, {}, ""};
    answered_.wait_for(lock, std::chrono::milliseconds(100));
  }
  Outcome out = std::move(outcomes_[ticket]);
  outcomes_.erase(ticket);
  return out;
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
  const Outcome out = submitAndWait(c);
  res.success = out.status.ok();
  res.message = out.status ? "applied " + out.when + " (published on ~applied_set)"
                           : "~set refused, nothing changed: " + out.status.error();
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
  const Outcome out = submitAndWait(c);
  res.success = out.status.ok();
  res.message = out.status ? "applied " + out.when + " (published on ~applied_obstacle)"
                           : "refused, nothing changed: " + out.status.error();
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
  const Outcome out = submitAndWait(c);
  res.success = out.status.ok();
  res.vertices = out.vertices;
  res.message = out.status ? "pinned " + std::to_string(out.vertices.size()) + " vertices " + out.when +
                                 " (published on ~applied_grasp)"
                           : "nothing pinned: " + out.status.error();
  return true;
}

void LiveServices::applied(const Command& command, const YAML::Node& document) {
  if (!std::holds_alternative<SetCommand>(command) && !std::holds_alternative<ObstacleCommand>(command)) return;
  std::lock_guard<std::mutex> lock(mutex_);
  document_ = YAML::Clone(document);
}

void LiveServices::answer(std::uint64_t ticket, const Status& outcome, const Command& command, std::uint64_t step,
                          double time) {
  Outcome out{outcome, {}, "at step " + std::to_string(step) + ", t = " + numberText(time) + " s"};
  if (const GraspCommand* g = std::get_if<GraspCommand>(&command); g != nullptr && outcome) out.vertices = g->vertices;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    outcomes_[ticket] = std::move(out);
  }
  answered_.notify_all();
}

}  // namespace fem_cloth
