#include "fem_cloth/ros/simulation_driver.h"

#include <tf2/exceptions.h>
#include <tf2_eigen/tf2_eigen.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <set>
#include <sstream>
#include <type_traits>

#include "fem_cloth/core/membrane.h"
#include "fem_cloth/ros/time_checks.h"
#include "fem_cloth/ros/transform_wait.h"

namespace fem_cloth {

namespace {

bool finite(const geometry_msgs::Point& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}
bool finite(const geometry_msgs::Vector3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// Vertex i of a coordinate vector with d values per vertex (positions, velocities, forces) as
// a 3D message (z = 0 in 2D).
template <class M>
M vertexMessage(const VectorX& values, int d, Index i) {
  M m;
  m.x = values[d * i];
  m.y = values[d * i + 1];
  m.z = d == 3 ? values[d * i + 2] : 0.0;
  return m;
}

// Vertex i of a coordinate vector with d values per vertex as a 3D vector (z = 0 in 2D).
Eigen::Vector3d vertexPoint(const VectorX& values, int d, Index i) {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  p.head(d) = values.segment(d * i, d);
  return p;
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

// "vertex 3" or "vertices 3, 7 and 12" (the first few of a long list, then how many more).
std::string verticesText(const std::vector<Index>& vertices) {
  constexpr std::size_t kListed = 6;
  std::string text = vertices.size() == 1 ? "vertex " : "vertices ";
  for (std::size_t k = 0; k < vertices.size() && k < kListed; ++k) {
    if (k > 0) text += k + 1 == vertices.size() ? " and " : ", ";
    text += std::to_string(vertices[k]);
  }
  if (vertices.size() > kListed) text += " and " + std::to_string(vertices.size() - kListed) + " more";
  return text;
}

}  // namespace

std::string stateHash(const VectorX& x, const VectorX& v) {
  std::uint64_t h = 14695981039346656037ull;
  auto feed = [&h](const VectorX& values) {
    const unsigned char* bytes = reinterpret_cast<const unsigned char*>(values.data());
    const std::size_t n = static_cast<std::size_t>(values.size()) * sizeof(double);
    for (std::size_t i = 0; i < n; ++i) {
      h ^= bytes[i];
      h *= 1099511628211ull;
    }
  };
  feed(x);
  feed(v);
  char text[17];
  std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(h));
  return text;
}

SimulationDriver::SimulationDriver(Simulation simulation, Scene scene, DriverSettings settings,
                                   const tf2::BufferCore* tf)
    : simulation_(std::move(simulation)),
      scene_(std::move(scene)),
      settings_(std::move(settings)),
      tf_(tf),
      pending_(settings_.maxPendingCommands) {}

ros::Time SimulationDriver::stampOf(double simulationTime) const {
  // epoch + ros::Duration(simulationTime), bit for bit, without rostime's exception: step() stops
  // before a state's stamp would leave the range, so the fallback is never a state's stamp.
  const Expected<ros::Time> t = checkedTimeAfter(settings_.epoch, simulationTime, "simulation time");
  return t ? *t : ros::TIME_MAX;
}

Expected<double> SimulationDriver::commandTime(const ros::Time& stamp) const {
  if (stamp.isZero()) return -1.0;
  return checkedSecondsSince(stamp, settings_.epoch, "header.stamp");
}

CommandCounts SimulationDriver::commandCounts(CommandTopic topic) const {
  CommandCounts c = counts_[static_cast<std::size_t>(topic)];
  c.pending = pending_.size(topic);
  return c;
}

bool SimulationDriver::isSimulationFrame(const std::string& frame) const {
  return frame.empty() || tfFrameName(frame) == tfFrameName(settings_.frame);
}

std::optional<Eigen::Isometry3d> SimulationDriver::transform(const std::string& frame,
                                                             const ros::Time& at,
                                                             std::string* why,
                                                             std::string* inexact) const {
  if (isSimulationFrame(frame)) return Eigen::Isometry3d::Identity();
  if (tf_ == nullptr) {
    if (why) *why = "frame '" + frame + "' needs tf, which is not available here";
    return std::nullopt;
  }
  const std::string source = tfFrameName(frame), target = tfFrameName(settings_.frame);
  if (!tf_->_frameExists(source)) {
    if (why) *why = "unknown frame '" + frame + "': tf has no such frame";
    return std::nullopt;
  }
  if (!tf_->_frameExists(target)) {
    if (why) {
      *why = "frame '" + frame + "' cannot be related to the simulation frame '" + target +
             "': tf has no transform to it";
    }
    return std::nullopt;
  }
  try {
    std::string error;
    if (tf_->canTransform(target, source, at, &error)) {
      return tf2::transformToEigen(tf_->lookupTransform(target, source, at));
    }
    // Not available at that time. Later than the newest transform (not yet received, or the
    // frame stopped): the newest serves if it is recent enough. Earlier (before the frame's
    // first transform, e.g. a frame that has just appeared): the oldest one, found by bisection
    // on canTransform, which holds on the whole span tf has kept.
    const geometry_msgs::TransformStamped latest = tf_->lookupTransform(target, source, ros::Time(0));
    if (latest.header.stamp.isZero()) return tf2::transformToEigen(latest);  // static transform
    if (at < latest.header.stamp) {
      ros::Time unavailable = at, available = latest.header.stamp;
      while (secondsBetween(available, unavailable) > 1e-6) {
        const ros::Time mid = unavailable + (available - unavailable) * 0.5;
        (tf_->canTransform(target, source, mid) ? available : unavailable) = mid;
      }
      const double gap = secondsBetween(available, at);
      if (gap <= settings_.tfTimeout) {
        if (inexact) {
          *inexact = "frame '" + frame + "' is not known yet at " + numberText(at.toSec()) +
                     " s; its first transform, " + numberText(gap) + " s later, stands in";
        }
        return tf2::transformToEigen(tf_->lookupTransform(target, source, available));
      }
      if (why) {
        *why = "frame '" + frame + "' is unknown at the time it is needed: its first transform " +
               "is " + numberText(gap) + " s later (tf_timeout = " + numberText(settings_.tfTimeout) + " s)";
      }
      return std::nullopt;
    }
    const double age = secondsBetween(at, latest.header.stamp);
    if (age <= settings_.tfTimeout) {
      if (inexact) {
        *inexact = "frame '" + frame + "' is not known yet at " + numberText(at.toSec()) +
                   " s; its newest transform, " + numberText(age) + " s older, stands in";
      }
      return tf2::transformToEigen(latest);
    }
    if (why) {
      *why = "frame '" + frame + "' is stale: its newest transform is " + numberText(age) +
             " s older than the time it is needed at (tf_timeout = " +
             numberText(settings_.tfTimeout) + " s)";
    }
  } catch (const tf2::TransformException& e) {
    if (why) *why = "frame '" + frame + "' is not connected to '" + target + "': " + e.what();
  } catch (const std::exception& e) {  // rostime's range errors, for transforms stamped far apart
    if (why) *why = "frame '" + frame + "': tf failed at " + numberText(at.toSec()) + " s: " + e.what();
  }
  return std::nullopt;
}

bool SimulationDriver::knownOrNeverWillBe(const std::string& frame, const ros::Time& at) const {
  if (isSimulationFrame(frame)) return true;
  if (tf_ == nullptr) return false;
  const std::string source = tfFrameName(frame), target = tfFrameName(settings_.frame);
  if (!tf_->_frameExists(source) || !tf_->_frameExists(target)) return false;
  try {
    if (tf_->canTransform(target, source, at)) return true;
  } catch (const std::exception&) {  // rostime's range errors: transform() says what
    return true;
  }
  const std::optional<ros::Time> newest = newestTransform(*tf_, target, source);
  return newest && at <= *newest;  // nullopt: not connected (yet)
}

std::vector<std::pair<std::string, double>> SimulationDriver::neededTransforms() const {
  const double t = simulator().time();
  const double dt = simulator().settings().dt;
  std::vector<std::pair<std::string, double>> needed;
  for (const Command* c : pending_.due(t + 1e-9 * dt)) {
    const std::string& frame =
        std::visit([](const auto& command) -> const std::string& { return command.header.frame_id; }, *c);
    const bool release = std::holds_alternative<PinCommand>(*c) &&
                         std::get<PinCommand>(*c).action == PinCommand::RELEASE;
    const bool clear = std::holds_alternative<ForceCommand>(*c) &&
                       std::get<ForceCommand>(*c).action == ForceCommand::CLEAR;
    if (release || clear) continue;
    needed.emplace_back(frame, t);
    if (std::holds_alternative<PinCommand>(*c)) needed.emplace_back(frame, t + dt);
  }
  for (const auto& [vertex, follow] : follow_) needed.emplace_back(follow.frame, t + dt);
  if (const ContactModel* contact = simulator().contact()) {
    for (std::size_t k = 0; k < contact->numObstacles(); ++k) {
      const std::string& frame = contact->obstacle(k).frame;
      if (!frame.empty()) needed.emplace_back(frame, t + dt);
    }
  }
  return needed;
}

bool SimulationDriver::transformsReady(std::string* missing) const {
  for (const auto& [frame, when] : neededTransforms()) {
    if (knownOrNeverWillBe(frame, stampOf(when))) continue;
    if (missing != nullptr) *missing = "frame '" + frame + "' at t = " + numberText(when) + " s";
    return false;
  }
  return true;
}

std::vector<std::string> SimulationDriver::framesNotReady() const {
  std::vector<std::string> frames;
  for (const auto& [frame, when] : neededTransforms()) {
    if (std::find(frames.begin(), frames.end(), frame) != frames.end()) continue;
    if (!knownOrNeverWillBe(frame, stampOf(when))) frames.push_back(frame);
  }
  return frames;
}

Status SimulationDriver::checkFrame(const std::string& frame, const ros::Time& stamp) const {
  std::string why;
  if (!transform(frame, stamp.isZero() ? now() : stamp, &why)) return Error{why};
  return Status::success();
}

template <class C>
Status SimulationDriver::submitCommand(const C& c) {
  CommandCounts& counts = counts_[static_cast<std::size_t>(topicOf(Command(c)))];
  ++counts.received;
  // The stamp first: tf would throw on a time no ROS duration relates to its transforms.
  const Expected<double> time = commandTime(c.header.stamp);
  Status s = time ? check(c) : Status(Error{time.error()});
  if (s) s = pending_.push(*time, c);
  if (!s) ++counts.rejected;
  return s;
}

Status SimulationDriver::submit(const PinCommand& c) { return submitCommand(c); }
Status SimulationDriver::submit(const ForceCommand& c) { return submitCommand(c); }

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
  }
  return Status::success();
}

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

Status SimulationDriver::apply(const PinCommand& c) {
  Simulator& sim = simulator();
  const int d = sim.dim();
  if (c.action == PinCommand::RELEASE) {
    if (c.vertices.empty()) {
      sim.releaseAll();
      follow_.clear();
    }
    for (std::uint32_t v : c.vertices) {
      sim.release(static_cast<Index>(v));
      follow_.erase(static_cast<Index>(v));
    }
    return Status::success();
  }
  std::string why, inexact;
  const std::optional<Eigen::Isometry3d> T = transform(c.header.frame_id, now(), &why, &inexact);
  if (!T) return Error{why};
  std::vector<Index> vertices;
  std::vector<Eigen::Vector3d> locals, targets;
  for (std::size_t k = 0; k < c.vertices.size(); ++k) {
    const Index v = static_cast<Index>(c.vertices[k]);
    const Eigen::Vector3d local = c.action == PinCommand::PIN_AT_TARGETS
                                      ? Eigen::Vector3d(c.targets[k].x, c.targets[k].y, c.targets[k].z)
                                      : Eigen::Vector3d(T->inverse() * vertexPoint(sim.state().x, d, v));
    Eigen::Vector3d target = *T * local;
    if (d == 2) target.z() = 0.0;
    vertices.push_back(v);
    locals.push_back(local);
    targets.push_back(target);
  }
  // Checked for every vertex before any is pinned: a command is applied whole or not at all.
  if (Status s = checkJumps(vertices, targets); !s) return s;
  if (!inexact.empty()) warnings_.push_back("pin command: " + inexact);
  const bool follows = !isSimulationFrame(c.header.frame_id);
  for (std::size_t k = 0; k < vertices.size(); ++k) {
    if (Status s = sim.pin(vertices[k], targets[k]); !s) return s;
    if (follows) {
      follow_[vertices[k]] = Follow{c.header.frame_id, locals[k]};
    } else {
      follow_.erase(vertices[k]);
    }
  }
  return Status::success();
}

Status SimulationDriver::checkJumps(const std::vector<Index>& vertices,
                                    const std::vector<Eigen::Vector3d>& targets) const {
  const Simulator& sim = simulator();
  for (std::size_t k = 0; k < vertices.size(); ++k) {
    const double jump = (targets[k] - vertexPoint(sim.state().x, sim.dim(), vertices[k])).norm();
    if (!(jump <= settings_.maxPinJump)) {
      return Error{"the target of vertex " + std::to_string(vertices[k]) + " is " + numberText(jump) +
                   " m from where the vertex is (max_pin_jump = " + numberText(settings_.maxPinJump) +
                   " m): a pin would move it there within one step; pin it where it is and move "
                   "the target in smaller steps"};
    }
  }
  return Status::success();
}

Status SimulationDriver::apply(const ForceCommand& c) {
  Simulator& sim = simulator();
  if (c.action == ForceCommand::CLEAR) {
    if (c.vertices.empty()) sim.clearForces();
    for (std::uint32_t v : c.vertices) sim.clearForce(static_cast<Index>(v));
    return Status::success();
  }
  std::string why;
  const std::optional<Eigen::Isometry3d> T = transform(c.header.frame_id, now(), &why);
  if (!T) return Error{why};
  const double duration = c.duration > 0.0 ? c.duration : std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < c.vertices.size(); ++k) {
    const geometry_msgs::Vector3& f = c.forces.size() == 1 ? c.forces[0] : c.forces[k];
    const Eigen::Vector3d force = T->linear() * Eigen::Vector3d(f.x, f.y, f.z);
    if (Status s = sim.applyForce(static_cast<Index>(c.vertices[k]), force, duration); !s) return s;
  }
  return Status::success();
}

void SimulationDriver::followFrames(double endTime) {
  // One lookup per frame. A frame that fails (stale: its publisher has stopped) or that would
  // make a pin jump loses its followers; they stay pinned where they are, in the simulation frame.
  std::map<std::string, std::vector<Index>> byFrame;
  for (const auto& [vertex, follow] : follow_) byFrame[follow.frame].push_back(vertex);
  for (const auto& [frame, vertices] : byFrame) {
    std::string why, inexact;
    std::optional<Eigen::Isometry3d> T = transform(frame, stampOf(endTime), &why, &inexact);
    std::vector<Eigen::Vector3d> targets;
    for (Index v : vertices) {
      if (!T) break;
      targets.push_back(*T * follow_.at(v).local);
      if (simulator().dim() == 2) targets.back().z() = 0.0;
    }
    Status moved = T ? checkJumps(vertices, targets) : Status(Error{why});
    if (!moved) {
      for (Index v : vertices) follow_.erase(v);
      warnings_.push_back("the pins of " + verticesText(vertices) + " stop following frame '" + frame +
                          "' and stay where they are: " + moved.error());
      continue;
    }
    if (!inexact.empty()) {
      warnings_.push_back("the pins of " + verticesText(vertices) + ": " + inexact +
                          " (a replay of this run may differ)");
    }
    for (std::size_t k = 0; k < vertices.size(); ++k) simulator().pin(vertices[k], targets[k]);
  }
}

StepReport SimulationDriver::step() {
  Simulator& sim = simulator();
  const double t = sim.time();
  const double dt = sim.settings().dt;
  // Every state is stamped with its ROS time: a run stops before that would leave the range.
  if (Expected<ros::Time> end = checkedTimeAfter(settings_.epoch, t + dt, "the end of the step at simulation time");
      !end) {
    StepReport refused;
    refused.ok = false;
    refused.retryable = false;
    refused.error = end.error();
    return refused;
  }
  for (Command& c : pending_.takeDue(t + 1e-9 * dt)) {
    CommandCounts& counts = counts_[static_cast<std::size_t>(topicOf(c))];
    const Status s = std::visit([this](const auto& command) { return apply(command); }, c);
    if (!s) {
      ++counts.rejected;
      warnings_.push_back(std::string("~") + topicName(topicOf(c)) +
                          " command could not be applied at t = " + numberText(t) + " s: " + s.error());
      continue;
    }
    ++counts.applied;
    std::visit(
        [this, t](auto command) {
          command.header.stamp = stampOf(t);
          if constexpr (std::is_same_v<decltype(command), PinCommand>) {
            appliedPins_.push_back(std::move(command));
          } else {
            appliedForces_.push_back(std::move(command));
          }
        },
        std::move(c));
  }
  if (Status s = simulation_.script.applyDue(sim); !s) warnings_.push_back(s.error());
  followFrames(t + dt);
  followObstacleFrames(t, t + dt);
  return sim.step();
}

void SimulationDriver::followObstacleFrames(double time, double endTime) {
  ContactModel* contact = simulator().contact();
  if (contact == nullptr) return;
  for (std::size_t k = 0; k < contact->numObstacles(); ++k) {
    const Obstacle& o = contact->obstacle(k);
    if (o.frame.empty()) continue;
    std::string why, inexact;
    auto pose = [&](double when) { return transform(o.frame, stampOf(when), &why, &inexact); };
    auto last = obstacleFrame_.find(k);
    // The start of this step is the end of the last; the first step starts where the frame is.
    std::optional<Eigen::Isometry3d> start;
    if (last != obstacleFrame_.end()) start = last->second;
    else start = pose(time);
    std::optional<Eigen::Isometry3d> end = pose(endTime);
    if (!start) {
      warnings_.push_back("obstacle '" + o.name + "' is not placed yet: " + why);
      continue;
    }
    if (!end) {
      warnings_.push_back("obstacle '" + o.name + "' stays where it is: " + why);
      end = start;
    } else if (!inexact.empty()) {
      warnings_.push_back("obstacle '" + o.name + "': " + inexact + " (a replay of this run may differ)");
    }
    contact->setFramePose(k, *start, *end);
    obstacleFrame_[k] = *end;
  }
}

void SimulationDriver::reset() {
  simulator().reset();
  simulation_.script.rewind();
  const std::array<std::uint64_t, kCommandTopics> dropped = pending_.clear();
  for (std::size_t k = 0; k < kCommandTopics; ++k) counts_[k].discarded += dropped[k];
  follow_.clear();
  obstacleFrame_.clear();
  appliedPins_.clear();
  appliedForces_.clear();
}

std::vector<PinCommand> SimulationDriver::takeAppliedPins() {
  std::vector<PinCommand> out;
  out.swap(appliedPins_);
  return out;
}

std::vector<ForceCommand> SimulationDriver::takeAppliedForces() {
  std::vector<ForceCommand> out;
  out.swap(appliedForces_);
  return out;
}

std::vector<std::string> SimulationDriver::takeWarnings() {
  std::vector<std::string> out;
  out.swap(warnings_);
  return out;
}

shape_msgs::Mesh SimulationDriver::meshMessage() const {
  const Mesh& mesh = *simulation_.mesh;
  shape_msgs::Mesh msg;
  msg.triangles.resize(mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      msg.triangles[t].vertex_indices[k] = static_cast<std::uint32_t>(mesh.triangles[t][k]);
    }
  }
  msg.vertices.resize(static_cast<std::size_t>(mesh.numVertices()));
  for (Index i = 0; i < mesh.numVertices(); ++i) {
    msg.vertices[static_cast<std::size_t>(i)] =
        vertexMessage<geometry_msgs::Point>(mesh.restPositions, mesh.dim, i);
  }
  return msg;
}

ClothState SimulationDriver::stateMessage() const {
  const State& s = simulator().state();
  const int d = simulator().dim();
  const Index n = simulator().model().numVertices();
  ClothState msg;
  msg.header.stamp = now();
  msg.header.frame_id = settings_.frame;
  msg.step = s.step;
  msg.positions.resize(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) {
    msg.positions[static_cast<std::size_t>(i)] = vertexMessage<geometry_msgs::Point>(s.x, d, i);
  }
  if (settings_.publishVelocities) {
    msg.velocities.resize(static_cast<std::size_t>(n));
    for (Index i = 0; i < n; ++i) {
      msg.velocities[static_cast<std::size_t>(i)] =
          vertexMessage<geometry_msgs::Vector3>(s.v, d, i);
    }
  }
  msg.state_hash = stateHash(s.x, s.v);
  return msg;
}

ClothEnergy SimulationDriver::energyMessage() {
  const EnergyReport e = simulator().energies();
  ClothEnergy msg;
  msg.header.stamp = now();
  msg.header.frame_id = settings_.frame;
  msg.step = stepIndex();
  msg.kinetic = e.kinetic;
  msg.strain = e.strain;
  msg.bending = e.bending;
  msg.gravity = e.gravity;
  msg.external_work = e.externalWork;
  msg.pin_work = e.pinWork;
  msg.dissipated = e.dissipated;
  msg.total = e.total;
  msg.balance_error = e.balanceError;
  return msg;
}

StepStats SimulationDriver::statsMessage(const StepReport& r, double wallTime,
                                         double realTimeFactor) const {
  StepStats msg;
  msg.header.stamp = now();
  msg.header.frame_id = settings_.frame;
  msg.step = stepIndex();
  msg.integrator = simulation_.simulator->integrator().name();
  msg.dt = simulator().settings().dt;
  msg.wall_time = wallTime;
  msg.real_time_factor = realTimeFactor;
  msg.substeps = static_cast<std::uint32_t>(r.substeps);
  msg.newton_iterations = static_cast<std::uint32_t>(r.newtonIterations);
  msg.residual = r.residual;
  msg.line_search_backtracks = static_cast<std::uint32_t>(r.lineSearchBacktracks);
  msg.rollbacks = static_cast<std::uint32_t>(r.rollbacks);
  msg.min_area_ratio = minAreaRatio(simulator().model().mesh(), simulator().model().rest(),
                                    simulator().state().x);
  msg.contacts = static_cast<std::uint32_t>(std::max(r.contacts, 0));
  msg.pin_commands = toMsg(commandCounts(CommandTopic::Pin));
  msg.force_commands = toMsg(commandCounts(CommandTopic::Force));
  return msg;
}

PinForces SimulationDriver::pinForcesMessage() const {
  const int d = simulator().dim();
  const VectorX reactions = simulator().pinReactions();
  PinForces msg;
  msg.header.stamp = now();
  msg.header.frame_id = settings_.frame;
  for (Index v : simulator().pinnedVertices()) {
    msg.vertices.push_back(static_cast<std::uint32_t>(v));
    msg.forces.push_back(vertexMessage<geometry_msgs::Vector3>(reactions, d, v));
  }
  return msg;
}

std::vector<geometry_msgs::WrenchStamped> SimulationDriver::pinWrenchMessages() const {
  const int d = simulator().dim();
  const VectorX reactions = simulator().pinReactions();
  std::map<std::string, std::pair<Eigen::Vector3d, Eigen::Vector3d>> sums;  // force, torque
  std::map<std::string, Eigen::Isometry3d> frames;
  for (Index v : simulator().pinnedVertices()) {
    auto it = follow_.find(v);
    const std::string frame = it == follow_.end() ? settings_.frame : it->second.frame;
    if (!frames.count(frame)) {
      std::string why;
      const std::optional<Eigen::Isometry3d> T = transform(frame, now(), &why);
      if (!T) continue;
      frames[frame] = *T;
      sums[frame] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
    }
    const Eigen::Vector3d f = vertexPoint(reactions, d, v), p = vertexPoint(simulator().state().x, d, v);
    auto& [force, torque] = sums[frame];
    force += f;
    torque += (p - frames[frame].translation()).cross(f);
  }
  std::vector<geometry_msgs::WrenchStamped> out;
  for (const auto& [frame, sum] : sums) {
    const Eigen::Matrix3d Rt = frames[frame].linear().transpose();
    const Eigen::Vector3d f = Rt * sum.first, tau = Rt * sum.second;
    geometry_msgs::WrenchStamped w;
    w.header.stamp = now();
    w.header.frame_id = frame;
    tf2::toMsg(f, w.wrench.force);
    tf2::toMsg(tau, w.wrench.torque);
    out.push_back(w);
  }
  return out;
}

std::vector<std::string> SimulationDriver::obstacleNames() const {
  std::vector<std::string> names;
  if (const ContactModel* contact = simulator().contact()) {
    for (std::size_t k = 0; k < contact->numObstacles(); ++k) names.push_back(contact->obstacle(k).name);
  }
  return names;
}

namespace {

geometry_msgs::Pose poseMessage(const Eigen::Isometry3d& T) {
  geometry_msgs::Pose p;
  const Eigen::Quaterniond q(T.linear());
  p.position.x = T.translation().x();
  p.position.y = T.translation().y();
  p.position.z = T.translation().z();
  p.orientation.x = q.x();
  p.orientation.y = q.y();
  p.orientation.z = q.z();
  p.orientation.w = q.w();
  return p;
}

// Side (m) of the square slab that stands for an infinite plane in RViz, and its thickness.
constexpr double kPlaneMarkerSide = 4.0, kPlaneMarkerThickness = 0.002;

}  // namespace

visualization_msgs::MarkerArray SimulationDriver::obstacleMarkers() const {
  visualization_msgs::MarkerArray array;
  const ContactModel* contact = simulator().contact();
  if (contact == nullptr) return array;
  for (std::size_t k = 0; k < contact->numObstacles(); ++k) {
    const Shape& shape = contact->obstacle(k).shape;
    const Eigen::Isometry3d pose = contact->shapePose(k);
    visualization_msgs::Marker m;
    m.header.stamp = now();
    m.header.frame_id = settings_.frame;
    m.ns = "obstacles";
    m.id = static_cast<int>(3 * k);
    m.action = visualization_msgs::Marker::ADD;
    m.color.r = m.color.g = m.color.b = 0.6f;
    m.color.a = 0.8f;
    m.pose = poseMessage(pose);
    switch (shape.type) {
      case ShapeType::Plane:
        // The slab's top face is the plane (its own z = 0, normal +z).
        m.type = visualization_msgs::Marker::CUBE;
        m.pose = poseMessage(pose * Eigen::Translation3d(0.0, 0.0, -0.5 * kPlaneMarkerThickness));
        m.scale.x = m.scale.y = kPlaneMarkerSide;
        m.scale.z = kPlaneMarkerThickness;
        break;
      case ShapeType::Box:
        m.type = visualization_msgs::Marker::CUBE;
        m.scale.x = 2.0 * shape.halfExtents.x();
        m.scale.y = 2.0 * shape.halfExtents.y();
        m.scale.z = 2.0 * shape.halfExtents.z();
        break;
      case ShapeType::Sphere:
        m.type = visualization_msgs::Marker::SPHERE;
        m.scale.x = m.scale.y = m.scale.z = 2.0 * shape.radius;
        break;
      case ShapeType::Capsule:
        m.type = visualization_msgs::Marker::CYLINDER;
        m.scale.x = m.scale.y = 2.0 * shape.radius;
        m.scale.z = 2.0 * shape.halfLength;
        for (int end = 0; end < 2; ++end) {
          visualization_msgs::Marker cap = m;
          cap.id = static_cast<int>(3 * k) + 1 + end;
          cap.type = visualization_msgs::Marker::SPHERE;
          cap.scale.z = 2.0 * shape.radius;
          cap.pose = poseMessage(pose * Eigen::Translation3d(0.0, 0.0, end == 0 ? -shape.halfLength
                                                                                : shape.halfLength));
          array.markers.push_back(cap);
        }
        break;
    }
    array.markers.push_back(m);
  }
  return array;
}

std::vector<geometry_msgs::WrenchStamped> SimulationDriver::obstacleWrenchMessages() const {
  std::vector<geometry_msgs::WrenchStamped> out;
  const ContactModel* contact = simulator().contact();
  if (contact == nullptr) return out;
  for (std::size_t k = 0; k < contact->numObstacles(); ++k) {
    const ObstacleWrench& w = contact->wrenches()[k];
    // The model gives the torque about the simulation frame's origin; move it to the shape's.
    const Eigen::Vector3d origin = contact->shapePose(k).translation();
    const Eigen::Vector3d torque = w.torque - origin.cross(w.force);
    geometry_msgs::WrenchStamped msg;
    msg.header.stamp = now();
    msg.header.frame_id = settings_.frame;
    tf2::toMsg(w.force, msg.wrench.force);
    tf2::toMsg(torque, msg.wrench.torque);
    out.push_back(msg);
  }
  return out;
}

}  // namespace fem_cloth
