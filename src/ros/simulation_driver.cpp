#include "fem_cloth/ros/simulation_driver.h"

#include <ros/names.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <set>
#include <sstream>
#include <type_traits>

#include "fem_cloth/core/live_change.h"
#include "fem_cloth/core/membrane.h"
#include "fem_cloth/ros/time_checks.h"
#include "fem_cloth/ros/time_text.h"
#include "fem_cloth/ros/transform_wait.h"

namespace fem_cloth {

namespace {

bool finite(const geometry_msgs::Point& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}
bool finite(const geometry_msgs::Vector3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

Status checkVertices(const std::vector<std::uint32_t>& vertices, Index numVertices) {
  std::set<std::uint32_t> seen;
  for (std::size_t k = 0; k < vertices.size(); ++k) {
    const std::uint32_t v = vertices[k];
    if (v >= static_cast<std::uint32_t>(numVertices)) {
      return Error{"vertex " + std::to_string(v) + " (vertices[" + std::to_string(k) +
                   "]) does not exist: the mesh has vertices 0 to " +
                   std::to_string(numVertices - 1)};
    }
    if (!seen.insert(v).second) {
      return Error{"vertex " + std::to_string(v) + " is listed twice"};
    }
  }
  return Status::success();
}

}  // namespace

SimulationDriver::SimulationDriver(Simulation simulation, DriverSettings settings, const tf2::BufferCore* tf,
                                   YAML::Node document)
    : simulation_(std::move(simulation)),
      settings_(std::move(settings)),
      timeline_(settings_.epoch),
      document_(std::move(document)),
      frames_(tf, settings_.frame, settings_.tfTimeout),
      pending_(settings_.maxPendingCommands),
      pinSet_(settings_.maxPinJump) {}

ros::Time SimulationDriver::stampOf(double simulationTime) const {
  // In the segment of the current step (the step being taken starts and ends in it); the first
  // segment's is epoch + ros::Duration(simulationTime), bit for bit, without rostime's exception:
  // step() stops before a state's stamp would leave the range, so the fallback is never a
  // state's stamp.
  const Expected<ros::Time> t = timeline_.stampOf(stepIndex(), simulationTime, "simulation time");
  return t ? *t : ros::TIME_MAX;
}

Expected<double> SimulationDriver::commandTime(const ros::Time& stamp) const {
  if (stamp.isZero()) return -1.0;
  return timeline_.timeOf(stamp, simulator().settings().dt, "header.stamp");
}

void SimulationDriver::setTimeline(Timeline timeline) {
  timeline_ = std::move(timeline);
  settings_.epoch = timeline_.origin();
  timeline_.reach(stepIndex(), simulator().time());
  retimePending();
}

void SimulationDriver::startSegment(const ros::Time& stamp) {
  timeline_.start(stepIndex(), simulator().time(), stamp);
  retimePending();
}

void SimulationDriver::retimePending() {
  pending_.retime([this](const Command& c, double before) {
    const Expected<double> t = commandTime(headerOf(c).stamp);
    return t ? *t : before;  // checked against the timeline when it came: cannot fail
  });
}

CommandCounts SimulationDriver::commandCounts(CommandTopic topic) const {
  CommandCounts c = counts_[static_cast<std::size_t>(topic)];
  c.pending = pending_.size(topic);
  return c;
}

template <>
std::vector<int> SimulationDriver::transformTimes(const PinCommand& c) const {
  // The frame's pose now places the pin (and checks its jump); at the step's end it follows.
  if (c.action == PinCommand::RELEASE) return {};
  return {0, 1};
}

template <>
std::vector<int> SimulationDriver::transformTimes(const ForceCommand& c) const {
  if (c.action == ForceCommand::CLEAR) return {};
  return {0};
}

template <>
std::vector<int> SimulationDriver::transformTimes(const SetCommand&) const {
  return {};
}

template <>
std::vector<int> SimulationDriver::transformTimes(const ObstacleCommand&) const {
  return {};  // an obstacle that follows a frame waits for it like every obstacle does
}

template <>
std::vector<int> SimulationDriver::transformTimes(const GraspCommand&) const {
  return {0, 1};  // like a pin: placed now, following at the step's end
}

std::vector<std::pair<std::string, double>> SimulationDriver::neededTransforms() const {
  const double t = simulator().time();
  const double dt = simulator().settings().dt;
  std::vector<std::pair<std::string, double>> needed;
  for (const Command* c : pending_.due(t + 1e-9 * dt)) {
    const std::vector<int> times = std::visit([this](const auto& command) { return transformTimes(command); }, *c);
    for (int end : times) needed.emplace_back(headerOf(*c).frame_id, end == 0 ? t : t + dt);
  }
  for (const std::string& frame : pinSet_.frames()) needed.emplace_back(frame, t + dt);
  if (const ObstacleSet* obstacles = simulator().obstacles()) {
    for (std::size_t k = 0; k < obstacles->size(); ++k) {
      const std::string& frame = (*obstacles)[k].frame;
      if (!frame.empty()) needed.emplace_back(frame, t + dt);
    }
  }
  return needed;
}

bool SimulationDriver::transformsReady(std::string* missing) const {
  for (const auto& [frame, when] : neededTransforms()) {
    if (frames_.knownOrNeverWillBe(frame, stampOf(when))) continue;
    if (missing != nullptr) *missing = "frame '" + frame + "' at t = " + numberText(when) + " s";
    return false;
  }
  return true;
}

std::vector<std::string> SimulationDriver::framesNotReady() const {
  std::vector<std::string> frames;
  for (const auto& [frame, when] : neededTransforms()) {
    if (std::find(frames.begin(), frames.end(), frame) != frames.end()) continue;
    if (!frames_.knownOrNeverWillBe(frame, stampOf(when))) frames.push_back(frame);
  }
  return frames;
}

Status SimulationDriver::checkFrame(const std::string& frame, const ros::Time& stamp) const {
  const FramePose pose = frames_.pose(frame, stamp.isZero() ? now() : stamp);
  if (!pose.pose) return Error{pose.why};
  return Status::success();
}

std::string graspWrenchTopic(const std::string& frame) {
  std::string out;
  for (char c : tfFrameName(frame)) out += std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '/' ? c : '_';
  if (out.empty() || std::isdigit(static_cast<unsigned char>(out[0]))) out = "frame_" + out;
  return "grasp/" + out + "/wrench";
}

Status SimulationDriver::checkWrenchTopic(const std::string& frame) const {
  if (frames_.isSimulationFrame(frame)) return Status::success();
  const std::string mine = tfFrameName(frame), topic = graspWrenchTopic(frame);
  std::vector<std::string> others = pinSet_.frames();
  others.push_back(settings_.frame);
  for (const std::string& other : others) {
    if (tfFrameName(other) == mine || graspWrenchTopic(other) != topic) continue;
    return Error{"frame '" + printableText(mine, 100) + "' would share the wrench topic ~" + topic + " with frame '" +
                 printableText(tfFrameName(other), 100) + "'" +
                 (frames_.isSimulationFrame(other) ? " (the simulation frame)" : ", which pins follow") +
                 ": refused (release those pins first, or use a frame name that differs in letters, digits or '_')"};
  }
  return Status::success();
}

template <>
Status SimulationDriver::check(const PinCommand& c) const {
  const Index n = simulator().model().numVertices();
  if (c.action > PinCommand::RELEASE) {
    return Error{"unknown action " + std::to_string(c.action) +
                 " (PIN_AT_TARGETS = 0, PIN_IN_PLACE = 1, RELEASE = 2)"};
  }
  if (Status s = checkVertices(c.vertices, n); !s) return s;
  if (c.action == PinCommand::PIN_AT_TARGETS) {
    if (c.vertices.empty()) return Error{"PIN_AT_TARGETS lists no vertices"};
    if (c.targets.size() != c.vertices.size()) {
      return Error{"PIN_AT_TARGETS has " + std::to_string(c.vertices.size()) + " vertices but " +
                   std::to_string(c.targets.size()) + " targets (one per vertex)"};
    }
    for (std::size_t k = 0; k < c.targets.size(); ++k) {
      if (!finite(c.targets[k])) {
        return Error{"target " + std::to_string(k) + " (vertex " + std::to_string(c.vertices[k]) +
                     ") is not finite"};
      }
    }
  } else if (!c.targets.empty()) {
    return Error{std::string(c.action == PinCommand::PIN_IN_PLACE ? "PIN_IN_PLACE" : "RELEASE") +
                 " takes no targets, got " + std::to_string(c.targets.size())};
  }
  if (c.action == PinCommand::PIN_IN_PLACE && c.vertices.empty()) {
    return Error{"PIN_IN_PLACE lists no vertices"};
  }
  if (c.action != PinCommand::RELEASE) {
    if (Status s = checkFrame(c.header.frame_id, c.header.stamp); !s) return s;
    if (Status s = checkWrenchTopic(c.header.frame_id); !s) return s;
  }
  return Status::success();
}

template <>
Status SimulationDriver::check(const ForceCommand& c) const {
  const Index n = simulator().model().numVertices();
  if (c.action > ForceCommand::CLEAR) {
    return Error{"unknown action " + std::to_string(c.action) + " (APPLY = 0, CLEAR = 1)"};
  }
  if (Status s = checkVertices(c.vertices, n); !s) return s;
  if (c.action == ForceCommand::APPLY) {
    if (c.vertices.empty()) return Error{"APPLY lists no vertices"};
    if (c.forces.size() != 1 && c.forces.size() != c.vertices.size()) {
      return Error{"APPLY has " + std::to_string(c.vertices.size()) + " vertices but " +
                   std::to_string(c.forces.size()) +
                   " forces (give one per vertex, or one for all)"};
    }
    for (std::size_t k = 0; k < c.forces.size(); ++k) {
      if (!finite(c.forces[k])) return Error{"force " + std::to_string(k) + " is not finite"};
    }
    if (!std::isfinite(c.duration) || c.duration < 0.0) {
      return Error{"duration must be finite and >= 0 s (0 = until cleared), got " + numberText(c.duration)};
    }
    if (Status s = checkFrame(c.header.frame_id, c.header.stamp); !s) return s;
  } else if (!c.forces.empty()) {
    return Error{"CLEAR takes no forces, got " + std::to_string(c.forces.size())};
  }
  return Status::success();
}

Status SimulationDriver::needsDocument() const {
  if (!document_ || document_.IsNull()) return Error{"live changes need the scene document, which this driver was not given"};
  return Status::success();
}

template <>
Status SimulationDriver::check(const SetCommand& c) const {
  if (Status s = needsDocument(); !s) return s;
  const Expected<LiveChange> change = applyLiveChange(document_, c.pairs);
  return change ? Status::success() : Status(Error{change.error()});
}

namespace {

Expected<ObstacleEdit> obstacleChange(const ObstacleCommand& c) {
  switch (c.action) {
    case ObstacleCommand::ADD: return ObstacleEdit::Add;
    case ObstacleCommand::REMOVE: return ObstacleEdit::Remove;
    case ObstacleCommand::MOVE: return ObstacleEdit::Move;
    default: return Error{"unknown action " + std::to_string(c.action) + " (ADD = 0, REMOVE = 1, MOVE = 2)"};
  }
}

}  // namespace

Status obstacleCommandProblem(const YAML::Node& document, const ObstacleCommand& c) {
  const Expected<ObstacleEdit> kind = obstacleChange(c);
  if (!kind) return Error{kind.error()};
  if (*kind == ObstacleEdit::Add) {
    if (Status s = obstacleNameProblem(c.name); !s) return s;
  }
  const Expected<LiveChange> change = applyObstacleChange(document, *kind, c.name, c.entry);
  return change ? Status::success() : Status(Error{change.error()});
}

Status graspShapeProblem(const GraspCommand& c) {
  if (!std::isfinite(c.radius) || !(c.radius > 0.0)) {
    return Error{"radius must be finite and > 0 m, got " + numberText(c.radius)};
  }
  if (!finite(c.point)) return Error{"point is not finite"};
  return Status::success();
}

template <>
Status SimulationDriver::check(const ObstacleCommand& c) const {
  if (Status s = needsDocument(); !s) return s;
  return obstacleCommandProblem(document_, c);
}

template <>
Status SimulationDriver::check(const GraspCommand& c) const {
  if (Status s = graspShapeProblem(c); !s) return s;
  if (Status s = checkFrame(c.header.frame_id, c.header.stamp); !s) return s;
  return checkWrenchTopic(c.header.frame_id);
}

Status SimulationDriver::submit(const Command& c, std::uint64_t ticket) {
  CommandCounts& counts = counts_[static_cast<std::size_t>(topicOf(c))];
  ++counts.received;
  // The stamp first: tf would throw on a time no ROS duration relates to its transforms.
  const Expected<double> time = commandTime(headerOf(c).stamp);
  Status s = time ? std::visit([this](const auto& command) { return check(command); }, c)
                  : Status(Error{time.error()});
  if (s) s = pending_.push(*time, c, simulator().time(), ticket);
  if (!s) ++counts.rejected;
  return s;
}

template <>
Status SimulationDriver::apply(PinCommand& c) {
  Simulator& sim = simulator();
  const std::vector<Index> vertices(c.vertices.begin(), c.vertices.end());
  if (c.action == PinCommand::RELEASE) {
    pinSet_.release(sim, vertices);
    return Status::success();
  }
  const FramePose T = frames_.pose(c.header.frame_id, now());
  if (!T.pose) return Error{T.why};
  if (Status s = checkWrenchTopic(c.header.frame_id); !s) return s;  // another frame took it meanwhile
  std::vector<Eigen::Vector3d> targets;
  if (c.action == PinCommand::PIN_AT_TARGETS) {
    for (const geometry_msgs::Point& p : c.targets) targets.emplace_back(p.x, p.y, p.z);
  }
  const std::string follows = frames_.isSimulationFrame(c.header.frame_id) ? "" : c.header.frame_id;
  if (Status s = pinSet_.pin(sim, vertices, targets, follows, *T.pose); !s) return s;
  if (!T.inexact.empty()) warnings_.push_back("pin command: " + T.inexact);
  return Status::success();
}

template <>
Status SimulationDriver::apply(ForceCommand& c) {
  Simulator& sim = simulator();
  if (c.action == ForceCommand::CLEAR) {
    if (c.vertices.empty()) sim.clearForces();
    for (std::uint32_t v : c.vertices) sim.clearForce(static_cast<Index>(v));
    return Status::success();
  }
  const FramePose T = frames_.pose(c.header.frame_id, now());
  if (!T.pose) return Error{T.why};
  const double duration = c.duration > 0.0 ? c.duration : std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < c.vertices.size(); ++k) {
    const geometry_msgs::Vector3& f = c.forces.size() == 1 ? c.forces[0] : c.forces[k];
    const Eigen::Vector3d force = T.pose->linear() * Eigen::Vector3d(f.x, f.y, f.z);
    if (Status s = sim.applyForce(static_cast<Index>(c.vertices[k]), force, duration); !s) return s;
  }
  return Status::success();
}

Status SimulationDriver::changeScene(Expected<LiveChange> change) {
  if (!change) return Error{change.error()};
  Expected<Simulation> next = changeLive(simulation_, change->scene);
  if (!next) return Error{next.error()};
  simulation_ = std::move(next).value();
  document_ = change->document;
  obstacleFrame_.clear();  // obstacles may have been added or removed: placed anew from their frames
  return Status::success();
}

template <>
Status SimulationDriver::apply(SetCommand& c) {
  if (Status s = needsDocument(); !s) return s;
  return changeScene(applyLiveChange(document_, c.pairs));
}

template <>
Status SimulationDriver::apply(ObstacleCommand& c) {
  if (Status s = needsDocument(); !s) return s;
  const Expected<ObstacleEdit> kind = obstacleChange(c);
  if (!kind) return Error{kind.error()};
  return changeScene(applyObstacleChange(document_, *kind, c.name, c.entry));
}

template <>
Status SimulationDriver::apply(GraspCommand& c) {
  Simulator& sim = simulator();
  const FramePose T = frames_.pose(c.header.frame_id, now());
  if (!T.pose) return Error{T.why};
  if (Status s = checkWrenchTopic(c.header.frame_id); !s) return s;
  Eigen::Vector3d centre = *T.pose * Eigen::Vector3d(c.point.x, c.point.y, c.point.z);
  if (sim.dim() == 2) centre.z() = 0.0;
  const Mesh& mesh = sim.model().mesh();
  std::vector<Index> vertices;
  for (Index v = 0; v < mesh.numVertices(); ++v) {
    if ((vertex3(mesh, sim.state().x, v) - centre).norm() <= c.radius) vertices.push_back(v);
  }
  if (vertices.empty()) {
    return Error{"no vertex within " + numberText(c.radius) + " m of (" + numberText(centre.x()) + ", " +
                 numberText(centre.y()) + ", " + numberText(centre.z()) + ") in the simulation frame"};
  }
  const std::string follows = frames_.isSimulationFrame(c.header.frame_id) ? "" : c.header.frame_id;
  if (Status s = pinSet_.pin(sim, vertices, {}, follows, *T.pose); !s) return s;
  if (!T.inexact.empty()) warnings_.push_back("grasp command: " + T.inexact);
  c.vertices.assign(vertices.begin(), vertices.end());
  return Status::success();
}

void SimulationDriver::applyDue(double t, bool ticketedOnly) {
  const double dt = simulator().settings().dt;
  std::vector<std::uint64_t> tickets;
  std::vector<Command> due = pending_.takeDue(t + 1e-9 * dt, &tickets, ticketedOnly);
  for (std::size_t k = 0; k < due.size(); ++k) {
    Command& c = due[k];
    CommandCounts& counts = counts_[static_cast<std::size_t>(topicOf(c))];
    const Status s = std::visit([this](auto& command) { return apply(command); }, c);
    if (!s) {
      ++counts.rejected;
      warnings_.push_back(std::string("~") + topicName(topicOf(c)) +
                          " command could not be applied at t = " + numberText(t) + " s: " + s.error());
      if (tickets[k] != 0) outcomes_.push_back(Outcome{tickets[k], s, c});
      continue;
    }
    ++counts.applied;
    std::visit([this, t](auto& command) { command.header.stamp = stampOf(t); }, c);
    if (tickets[k] != 0) outcomes_.push_back(Outcome{tickets[k], Status::success(), c});
    applied_.push_back(std::move(c));
  }
}

void SimulationDriver::applyTicketedNow() { applyDue(simulator().time(), true); }

bool SimulationDriver::ticketedDueNow() const {
  return pending_.ticketedDue(simulator().time() + 1e-9 * simulator().settings().dt);
}

std::vector<SimulationDriver::Outcome> SimulationDriver::takeOutcomes() {
  std::vector<Outcome> out;
  out.swap(outcomes_);
  return out;
}

std::vector<std::uint64_t> SimulationDriver::withdrawTicketed() {
  std::array<std::uint64_t, kCommandTopics> dropped{};
  const std::vector<std::uint64_t> tickets = pending_.withdrawTicketed(dropped);
  for (std::size_t k = 0; k < kCommandTopics; ++k) counts_[k].discarded += dropped[k];
  return tickets;
}

StepReport SimulationDriver::step() {
  const double t = simulator().time();
  const double dt = simulator().settings().dt;
  // Every state is stamped with its ROS time: a run stops before that would leave the range.
  if (Expected<ros::Time> end = timeline_.stampOf(stepIndex(), t + dt, "the end of the step at simulation time");
      !end) {
    StepReport refused;
    refused.ok = false;
    refused.retryable = false;
    refused.error = end.error();
    return refused;
  }
  frames_.forgetBefore(stampOf(t));
  applyDue(t);
  // Taken after the commands: a live change among them replaced the simulator.
  Simulator& sim = simulator();
  if (Status s = simulation_.script.applyDue(sim); !s) warnings_.push_back(s.error());
  const ros::Time end = stampOf(t + dt);
  for (std::string& w : pinSet_.follow(sim, [this, &end](const std::string& frame) { return frames_.pose(frame, end); })) {
    warnings_.push_back(std::move(w));
  }
  followObstacleFrames(t, t + dt);
  StepReport report = sim.step();
  if (!report.warning.empty()) warnings_.push_back(report.warning);
  if (report.ok && report.boxDepth > deepestIntoBox_.depth) {
    deepestIntoBox_ = {report.boxDepth, report.boxDepthWhere, stepIndex()};
  }
  // A segment rebuilt from a recording starts here: its simulation time is known now.
  if (report.ok && timeline_.reach(stepIndex(), simulator().time())) retimePending();
  return report;
}

void SimulationDriver::followObstacleFrames(double time, double endTime) {
  ObstacleSet* obstacles = simulator().obstacles();
  if (obstacles == nullptr) return;
  for (std::size_t k = 0; k < obstacles->size(); ++k) {
    const Obstacle& o = (*obstacles)[k];
    if (o.frame.empty()) continue;
    std::string why, inexact;
    auto pose = [&](double when) {
      FramePose p = frames_.pose(o.frame, stampOf(when));
      why = p.why;
      inexact = p.inexact;
      return p.pose;
    };
    auto last = obstacleFrame_.find(k);
    // The start of this step is the end of the last; the first step starts where the frame is.
    std::optional<Eigen::Isometry3d> start;
    if (last != obstacleFrame_.end()) start = last->second;
    else start = pose(time);
    if (!start) {
      // Which frame, at which time (the step's start): a frame published late, or stamped
      // behind the node, shows as such.
      warnings_.push_back("obstacle '" + o.name + "' is not placed yet: its frame '" + o.frame +
                          "' has no pose at the start of the step, t = " + numberText(time) + " s (ROS time " +
                          rosTimeText(stampOf(time)) + " s): " + why);
      continue;
    }
    std::optional<Eigen::Isometry3d> end = pose(endTime);
    if (!end) {
      warnings_.push_back("obstacle '" + o.name + "' stays where it is: " + why);
      end = start;
    } else if (!inexact.empty()) {
      warnings_.push_back("obstacle '" + o.name + "': " + inexact + " (a replay of this run may differ)");
    }
    obstacles->setFramePose(k, *start, *end);
    obstacleFrame_[k] = *end;
  }
}

void SimulationDriver::reset() {
  simulator().reset();
  simulation_.script.rewind();
  const std::array<std::uint64_t, kCommandTopics> dropped = pending_.clear();
  for (std::size_t k = 0; k < kCommandTopics; ++k) counts_[k].discarded += dropped[k];
  pinSet_.clear();
  obstacleFrame_.clear();
  applied_.clear();
  deepestIntoBox_ = BoxDepth();
  timeline_ = Timeline(timeline_.origin());
}

std::vector<Command> SimulationDriver::takeApplied() {
  std::vector<Command> out;
  out.swap(applied_);
  return out;
}

std::vector<std::string> SimulationDriver::takeWarnings() {
  std::vector<std::string> out;
  out.swap(warnings_);
  return out;
}

std::vector<GraspWrench> SimulationDriver::graspWrenches(const VectorX& reactions) const {
  return pinSet_.wrenches(simulator(), reactions, settings_.frame,
                          [this](const std::string& frame) { return framePose(frame); });
}

std::vector<std::string> SimulationDriver::obstacleNames() const {
  std::vector<std::string> names;
  if (const ObstacleSet* obstacles = simulator().obstacles()) {
    for (std::size_t k = 0; k < obstacles->size(); ++k) names.push_back((*obstacles)[k].name);
  }
  return names;
}

Status obstacleNameProblem(const std::string& name) {
  std::string why;
  if (!ros::names::validate(name, why) || name.find('/') != std::string::npos) {
    return Error{"obstacle '" + name + "': its name must be a valid ROS name without '/' (it names "
                 "the topic ~obstacles/<name>/wrench)"};
  }
  return Status::success();
}

StepStats statsMessage(const SimulationDriver& driver, const StepReport& report, double wallTime,
                       double realTimeFactor, const std::function<CommandCounts(CommandTopic)>& counts) {
  const Simulator& sim = driver.simulator();
  StepStats msg = toMsg(driver.header(), driver.stepIndex(), sim.integrator().name(), sim.settings().dt,
                        report, wallTime, realTimeFactor);
  msg.min_area_ratio = minAreaRatio(sim.model().mesh(), sim.model().rest(), sim.state().x);
  msg.box_depth = report.boxDepth;
  msg.box_depth_where = report.boxDepthWhere;
  const SimulationDriver::BoxDepth& deepest = driver.deepestIntoBox();
  msg.max_box_depth = deepest.depth;
  msg.max_box_depth_where = deepest.where;
  msg.max_box_depth_step = deepest.step;
  if (counts) {
    setCommandStats(msg, counts);
  } else {
    setCommandStats(msg, [&driver](CommandTopic topic) { return driver.commandCounts(topic); });
  }
  return msg;
}

std::vector<std::pair<std::string, std::string>> boxDepthDiagnostics(const SimulationDriver::BoxDepth& deepest) {
  return {{"deepest into a box between the vertices (mm)", numberText(1e3 * deepest.depth)},
          {"deepest into a box: where", deepest.where},
          {"deepest into a box: step", std::to_string(deepest.step)}};
}

std::string boxDepthWarning(const SimulationDriver::BoxDepth& deepest) {
  if (deepest.depth <= 0.0) return std::string();
  return "the cloth's surface reached " + numberText(1e3 * deepest.depth) + " mm into " + deepest.where +
         " between its vertices (step " + std::to_string(deepest.step) +
         "): only the vertices were kept out there, not edges and triangles (docs/contact.md)";
}

void setCommandStats(StepStats& msg, const std::function<CommandCounts(CommandTopic)>& counts) {
  msg.commands.clear();
  for (CommandTopic topic : commandTopics()) msg.commands.push_back(toMsg(topic, counts(topic)));
  msg.pin_commands = msg.commands[static_cast<std::size_t>(CommandTopic::Pin)];
  msg.force_commands = msg.commands[static_cast<std::size_t>(CommandTopic::Force)];
}

}  // namespace fem_cloth
