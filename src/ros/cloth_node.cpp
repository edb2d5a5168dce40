#include "fem_cloth/ros/cloth_node.h"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <ros/names.h>
#include <ros/package.h>
#include <std_msgs/String.h>
#include <rosgraph_msgs/Clock.h>

#include <cmath>
#include <sstream>

#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/ros/bag_io.h"
#include "fem_cloth/ros/scene_params.h"

namespace fem_cloth {

namespace {

std::string defaultSceneFile() {
  const std::string share = ros::package::getPath("fem_cloth");
  return share.empty() ? std::string() : share + "/config/hanging_cloth.yaml";
}

// Steps between publications for a rate in Hz (0: every step).
std::uint64_t everyFor(double rate, double dt) {
  if (rate <= 0.0) return 1;
  return std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::llround(1.0 / (rate * dt))));
}

}  // namespace

const std::vector<std::string>& ClothNode::parameterNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> own = {
        "scene_file",   "frame_id",      "time_mode",          "real_time_factor",
        "start_time",   "publish_rate",  "marker_rate",        "publish_velocities",
        "always_publish", "start_paused", "tf_timeout",        "step_lag",
        "replay_bag"};
    own.insert(own.end(), perceptionParameterNames().begin(), perceptionParameterNames().end());
    return own;
  }();
  return names;
}

ClothNode::ClothNode(ros::NodeHandle node, ros::NodeHandle privateNode)
    : node_(node), private_(privateNode) {}

ClothNode::~ClothNode() = default;

bool ClothNode::readParameters(std::string* error) {
  std::string mode = "real_time";
  if (!readParam(private_, "frame_id", frame_, error, "a string") ||
      !readParam(private_, "time_mode", mode, error, "a string (real_time or fast)") ||
      !readParam(private_, "real_time_factor", realTimeFactor_, error, "a number") ||
      !readParam(private_, "publish_rate", publishRate_, error, "a number (Hz)") ||
      !readParam(private_, "marker_rate", markerRate_, error, "a number (Hz)") ||
      !readParam(private_, "publish_velocities", publishVelocities_, error, "true or false") ||
      !readParam(private_, "always_publish", alwaysPublish_, error, "true or false") ||
      !readParam(private_, "start_paused", startPaused_, error, "true or false") ||
      !readParam(private_, "tf_timeout", tfTimeout_, error, "a number (s)") ||
      !readParam(private_, "step_lag", stepLag_, error, "a number (s)") ||
      !readParam(private_, "replay_bag", replayBag_, error, "a path")) {
    return false;
  }
  if (!(stepLag_ >= 0.0) || !std::isfinite(stepLag_)) {
    *error = "parameter ~step_lag must be >= 0 s";
    return false;
  }
  if (private_.hasParam("start_time")) {
    double seconds = 0.0;
    if (!private_.getParam("start_time", seconds) || !std::isfinite(seconds) || seconds < 0) {
      *error = "parameter ~start_time must be a number of seconds >= 0";
      return false;
    }
    startTime_ = ros::Time(seconds);
    hasStartTime_ = true;
  }
  if (frame_.empty()) {
    *error = "parameter ~frame_id must not be empty";
    return false;
  }
  if (mode == "real_time") {
    timeMode_ = TimeMode::RealTime;
  } else if (mode == "fast") {
    timeMode_ = TimeMode::Fast;
  } else {
    *error = "parameter ~time_mode must be real_time or fast, got '" + mode + "'";
    return false;
  }
  if (!(realTimeFactor_ > 0.0) || !std::isfinite(realTimeFactor_)) {
    *error = "parameter ~real_time_factor must be positive";
    return false;
  }
  if (!(publishRate_ >= 0.0) || !(markerRate_ >= 0.0)) {
    *error = "parameters ~publish_rate and ~marker_rate must be >= 0 Hz";
    return false;
  }
  if (!(tfTimeout_ > 0.0)) {
    *error = "parameter ~tf_timeout must be positive (s)";
    return false;
  }
  return true;
}

bool ClothNode::start(std::string* error) {
  if (!readParameters(error)) return false;
  std::string sourcePath;
  std::optional<RecordedRun> replay;
  if (!replayBag_.empty()) {
    Expected<RecordedRun> run = readRun(replayBag_, ros::this_node::getName());
    if (!run) {
      *error = "~replay_bag: " + run.error();
      return false;
    }
    replay = std::move(run).value();
  }
  Expected<YAML::Node> doc = Error{""};
  bool sceneKeys = private_.hasParam("scene_file") || private_.hasParam("mesh");
  if (replay && !sceneKeys) {
    if (replay->sceneYaml.empty()) {
      *error = "~replay_bag: " + replayBag_ + " holds no scene; give ~scene_file";
      return false;
    }
    try {
      doc = YAML::Load(replay->sceneYaml);
    } catch (const YAML::Exception& e) {
      *error = "~replay_bag: the stored scene is not valid YAML: " + e.msg;
      return false;
    }
    sourcePath = replayBag_;
  } else {
    doc = sceneDocumentFromParameters(private_, parameterNames(), defaultSceneFile(), &sourcePath);
  }
  if (!doc) {
    *error = doc.error();
    return false;
  }
  sceneText_ = sceneDocumentToString(*doc);
  Expected<Scene> scene = parseScene(*doc, sourcePath);
  if (!scene) {
    *error = "scene parameter " + scene.error();
    return false;
  }
  Expected<Simulation> simulation = buildSimulation(*scene);
  if (!simulation) {
    *error = "scene: " + simulation.error();
    return false;
  }
  for (const std::string& w : simulation->warnings) ROS_WARN_STREAM("fem_cloth_node: mesh: " << w);

  if (replay && !hasStartTime_) {
    if (std::optional<ros::Time> epoch = runEpoch(*replay, scene->dt)) {
      startTime_ = *epoch;
      hasStartTime_ = true;
    }
  }
  DriverSettings settings;
  settings.frame = frame_;
  settings.tfTimeout = tfTimeout_;
  settings.publishVelocities = publishVelocities_;
  const double dt = scene->dt;
  driver_ = std::make_unique<SimulationDriver>(std::move(simulation).value(), *scene, settings,
                                               &tfBuffer_);
  publishEvery_ = everyFor(publishRate_, dt);
  markerEvery_ = everyFor(markerRate_, dt);
  paused_ = startPaused_;

  tfListener_ = std::make_unique<tf2_ros::TransformListener>(tfBuffer_, node_);
  meshPub_ = private_.advertise<shape_msgs::Mesh>("mesh", 1, true);
  statePub_ = private_.advertise<ClothState>("state", 10);
  energyPub_ = private_.advertise<ClothEnergy>("energy", 10);
  statsPub_ = private_.advertise<StepStats>("stats", 10);
  pinForcesPub_ = private_.advertise<PinForces>("pin_forces", 10);
  pinWrenchPub_ = private_.advertise<geometry_msgs::WrenchStamped>("pin_wrench", 10);
  // Perception outputs (perception.h): ~points, ~camera/*, ~marker and tf frames.
  PerceptionSettings perception;
  perception.frame = frame_;
  perception.originFrame = ros::this_node::getName().substr(1);
  perception.alwaysPublish = alwaysPublish_;
  perception.clothFrames = replayBag_.empty();
  if (!readPerceptionParameters(private_, perception, error)) return false;
  Expected<std::unique_ptr<PerceptionOutputs>> outputs =
      PerceptionOutputs::create(private_, *driver_, tfBuffer_, std::move(perception));
  if (!outputs) {
    *error = outputs.error();
    return false;
  }
  perception_ = std::move(outputs).value();
  // Obstacles (only when the scene has some: a scene pays for what it declares).
  const std::vector<std::string> obstacles = driver_->obstacleNames();
  if (!obstacles.empty()) {
    obstacleMarkerPub_ = private_.advertise<visualization_msgs::MarkerArray>("obstacle_markers", 2, true);
  }
  for (const std::string& name : obstacles) {
    std::string why;
    if (!ros::names::validate(name, why) || name.find('/') != std::string::npos) {
      *error = "obstacle '" + name + "': its name must be a valid ROS name without '/' (it names "
               "the topic ~obstacles/<name>/wrench)";
      return false;
    }
    obstacleWrenchPubs_.push_back(
        private_.advertise<geometry_msgs::WrenchStamped>("obstacles/" + name + "/wrench", 10));
  }
  diagnosticsPub_ = node_.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 10);
  scenePub_ = private_.advertise<std_msgs::String>("scene", 1, true);
  appliedPinPub_ = private_.advertise<PinCommand>("applied_pin", 100);
  appliedForcePub_ = private_.advertise<ForceCommand>("applied_force", 100);
  if (timeMode_ == TimeMode::Fast) clockPub_ = node_.advertise<rosgraph_msgs::Clock>("/clock", 10);
  pinSub_ = private_.subscribe("pin", 100, &ClothNode::onPin, this);
  forceSub_ = private_.subscribe("force", 100, &ClothNode::onForce, this);
  resetSrv_ = private_.advertiseService("reset", &ClothNode::onReset, this);
  pauseSrv_ = private_.advertiseService("pause", &ClothNode::onPause, this);
  resumeSrv_ = private_.advertiseService("resume", &ClothNode::onResume, this);
  stepSrv_ = private_.advertiseService("step", &ClothNode::onStep, this);
  advanceSrv_ = private_.advertiseService("advance", &ClothNode::onAdvance, this);

  std::ostringstream info;
  const Simulator& sim = driver_->simulator();
  info << "fem_cloth_node: scene '" << scene->name << "' (" << (sourcePath.empty() ? "parameters" : sourcePath)
       << "): " << sim.model().numVertices() << " vertices, " << sim.model().mesh().numTriangles()
       << " triangles, " << scene->materialModel << ", " << sim.integrator().name() << " dt "
       << dt << " s, frame '" << frame_ << "', "
       << (timeMode_ == TimeMode::Fast ? "fast (publishing /clock)" : "real time");
  if (timeMode_ == TimeMode::RealTime && realTimeFactor_ != 1.0) info << " x" << realTimeFactor_;
  if (paused_) info << ", paused";
  ROS_INFO_STREAM(info.str());
  return true;
}

void ClothNode::reject(const std::string& topic, const std::string& why) {
  ++rejected_;
  lastProblem_ = "~" + topic + " rejected: " + why;
  ROS_WARN_STREAM("fem_cloth_node: " << lastProblem_);
  publishDiagnostics(true);
}

void ClothNode::onPin(const PinCommand::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (Status s = driver_->submit(*msg); !s) reject("pin", s.error());
}

void ClothNode::onForce(const ForceCommand::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (Status s = driver_->submit(*msg); !s) reject("force", s.error());
}

bool ClothNode::onReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  driver_->reset();
  wallEpoch_ = ros::Time::now();
  if (!hasStartTime_ && timeMode_ == TimeMode::RealTime) driver_->setEpoch(wallEpoch_);
  publishOutputs(StepReport(), 0.0, true);
  res.success = true;
  res.message = "reset to the initial state";
  wake_.notify_all();
  return true;
}

bool ClothNode::onPause(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  paused_ = true;
  res.success = true;
  res.message = "paused at t = " + std::to_string(driver_->simulator().time()) + " s";
  return true;
}

bool ClothNode::onResume(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (paused_) {
    // Real time restarts from here: the pause is not made up for. A recorder that subscribed
    // while we were paused gets the current state first.
    wallEpoch_ = ros::Time::now() - ros::Duration(driver_->simulator().time() / realTimeFactor_);
    if (!hasStartTime_ && timeMode_ == TimeMode::RealTime && driver_->stepIndex() == 0) {
      driver_->setEpoch(wallEpoch_);
    }
    publishOutputs(StepReport(), 0.0, true);
  }
  paused_ = false;
  res.success = true;
  res.message = "running";
  wake_.notify_all();
  return true;
}

bool ClothNode::onStep(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!paused_) {
    res.success = false;
    res.message = "~step advances a paused simulation; call ~pause first";
    return true;
  }
  ++stepRequests_;
  res.success = true;
  res.message = "stepping to t = " +
                std::to_string(driver_->simulator().time() + driver_->simulator().settings().dt) + " s";
  wake_.notify_all();
  return true;
}

bool ClothNode::onAdvance(Advance::Request& req, Advance::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!paused_) {
    res.success = false;
    res.message = "~advance steps a paused simulation; call ~pause first";
  } else {
    const std::uint32_t steps = std::max<std::uint32_t>(req.steps, 1);
    res.success = true;
    for (std::uint32_t k = 0; k < steps; ++k) {
      stepOnce();
      if (!driver_->simulator().lastReport().ok) {
        res.success = false;
        res.message = "step " + std::to_string(k + 1) + " of " + std::to_string(steps) +
                      " failed: " + driver_->simulator().lastReport().error;
        break;
      }
    }
    if (res.success) res.message = "advanced " + std::to_string(steps) + " steps";
    // The caller gets the state it stopped at, whatever the publish rate.
    if (driver_->stepIndex() % publishEvery_ != 0) {
      publishOutputs(driver_->simulator().lastReport(), stepWallTime_, true);
    }
  }
  res.step = driver_->stepIndex();
  res.time = driver_->simulator().time();
  res.state_hash = stateHash(driver_->simulator().state().x, driver_->simulator().state().v);
  return true;
}

void ClothNode::stepOnce() {
  const ros::WallTime begin = ros::WallTime::now();
  const StepReport report = driver_->step();
  stepWallTime_ = (ros::WallTime::now() - begin).toSec();
  // The commands as they took effect, stamped with their step: what a recording replays.
  for (const PinCommand& c : driver_->takeAppliedPins()) appliedPinPub_.publish(c);
  for (const ForceCommand& c : driver_->takeAppliedForces()) appliedForcePub_.publish(c);
  for (const std::string& w : driver_->takeWarnings()) {
    lastProblem_ = w;
    ROS_WARN_STREAM_THROTTLE(2.0, "fem_cloth_node: " << w);
  }
  if (!report.ok) {
    ++failedSteps_;
    lastProblem_ = report.error;
    ROS_ERROR_STREAM_THROTTLE(2.0, "fem_cloth_node: " << report.error);
  }
  // Real-time factor over windows of about a second of wall time.
  const double window = (ros::WallTime::now() - rtfWindowStart_).toSec();
  if (window >= 1.0) {
    realTimeFactorMeasured_ = (driver_->simulator().time() - rtfWindowSimStart_) / window;
    rtfWindowStart_ = ros::WallTime::now();
    rtfWindowSimStart_ = driver_->simulator().time();
    if (timeMode_ == TimeMode::RealTime && realTimeFactorMeasured_ < 0.9 * realTimeFactor_) {
      ROS_WARN_STREAM_THROTTLE(5.0, "fem_cloth_node: cannot keep up with real time: real-time factor "
                                        << realTimeFactorMeasured_ << " (a step takes "
                                        << 1e3 * stepWallTime_ << " ms for dt "
                                        << 1e3 * driver_->simulator().settings().dt << " ms)");
    }
  }
  publishClock();
  publishOutputs(report, stepWallTime_, false);
}

void ClothNode::publishClock() {
  if (timeMode_ != TimeMode::Fast) return;
  rosgraph_msgs::Clock clock;
  clock.clock = driver_->now();
  clockPub_.publish(clock);
}

void ClothNode::publishOutputs(const StepReport& report, double wallTime, bool force) {
  const std::uint64_t step = driver_->stepIndex();
  const bool stateDue = force || step % publishEvery_ == 0;
  const bool markerDue = force || step % markerEvery_ == 0;
  if (stateDue) {
    statePub_.publish(driver_->stateMessage());
    if (wanted(energyPub_)) energyPub_.publish(driver_->energyMessage());
    if (wanted(statsPub_)) statsPub_.publish(driver_->statsMessage(report, wallTime, realTimeFactorMeasured_));
    if (wanted(pinForcesPub_)) pinForcesPub_.publish(driver_->pinForcesMessage());
    if (wanted(pinWrenchPub_)) {
      for (const auto& w : driver_->pinWrenchMessages()) pinWrenchPub_.publish(w);
    }
    bool wrenchWanted = false;
    for (const ros::Publisher& pub : obstacleWrenchPubs_) wrenchWanted = wrenchWanted || wanted(pub);
    if (wrenchWanted) {
      const std::vector<geometry_msgs::WrenchStamped> wrenches = driver_->obstacleWrenchMessages();
      for (std::size_t k = 0; k < wrenches.size() && k < obstacleWrenchPubs_.size(); ++k) {
        obstacleWrenchPubs_[k].publish(wrenches[k]);
      }
    }
  }
  if (markerDue && obstacleMarkerPub_ && wanted(obstacleMarkerPub_)) {
    obstacleMarkerPub_.publish(driver_->obstacleMarkers());
  }
  perception_->publish(stateDue, markerDue);
  publishDiagnostics(false);
}

void ClothNode::publishDiagnostics(bool force) {
  const ros::WallTime now = ros::WallTime::now();
  if (!force && (now - lastDiagnostics_).toSec() < 1.0) return;
  lastDiagnostics_ = now;
  diagnostic_msgs::DiagnosticArray array;
  array.header.stamp = driver_->now();
  diagnostic_msgs::DiagnosticStatus status;
  status.name = ros::this_node::getName();
  status.hardware_id = "fem_cloth";
  status.level = failedSteps_ > 0 ? diagnostic_msgs::DiagnosticStatus::ERROR
                 : (rejected_ > 0 || !lastProblem_.empty()) ? diagnostic_msgs::DiagnosticStatus::WARN
                                                           : diagnostic_msgs::DiagnosticStatus::OK;
  status.message = lastProblem_.empty() ? "running" : lastProblem_;
  auto add = [&status](const std::string& key, const std::string& value) {
    diagnostic_msgs::KeyValue kv;
    kv.key = key;
    kv.value = value;
    status.values.push_back(kv);
  };
  add("simulation time (s)", std::to_string(driver_->simulator().time()));
  add("step", std::to_string(driver_->stepIndex()));
  add("real-time factor", std::to_string(realTimeFactorMeasured_));
  add("rejected commands", std::to_string(rejected_));
  add("failed steps", std::to_string(failedSteps_));
  add("paused", paused_ ? "true" : "false");
  array.status.push_back(status);
  diagnosticsPub_.publish(array);
}

void ClothNode::run() {
  ros::AsyncSpinner spinner(2);
  spinner.start();
  // Time origin: wait for a valid ROS time (with use_sim_time, the first /clock).
  if (timeMode_ == TimeMode::RealTime) {
    while (ros::ok() && ros::Time::now().isZero()) ros::WallDuration(0.001).sleep();
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    wallEpoch_ = ros::Time::now();
    const ros::Time epoch =
        hasStartTime_ ? startTime_ : (timeMode_ == TimeMode::Fast ? ros::Time(0) : wallEpoch_);
    driver_->setEpoch(epoch);
    if (hasStartTime_ && timeMode_ == TimeMode::RealTime) wallEpoch_ = epoch;
    rtfWindowStart_ = ros::WallTime::now();
    meshPub_.publish(driver_->meshMessage());
    // Latched: RViz started later, or a paused node, still shows where the obstacles are.
    if (obstacleMarkerPub_) obstacleMarkerPub_.publish(driver_->obstacleMarkers());
    std_msgs::String sceneMsg;
    sceneMsg.data = sceneText_;
    scenePub_.publish(sceneMsg);
    publishClock();
    publishOutputs(StepReport(), 0.0, true);
  }
  const double dt = driver_->simulator().settings().dt;
  while (ros::ok()) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (paused_ && stepRequests_ == 0) {
      wake_.wait_for(lock, std::chrono::milliseconds(50));
      continue;
    }
    if (!paused_ && timeMode_ == TimeMode::RealTime) {
      // The step that ends at simulation time t + dt is due at wallEpoch + (t + dt) / factor.
      const ros::Time due = wallEpoch_ +
                            ros::Duration((driver_->simulator().time() + dt) / realTimeFactor_ +
                                          stepLag_);
      const ros::Time now = ros::Time::now();
      if (now < due) {
        lock.unlock();
        const double wait = std::min((due - now).toSec(), 0.05);
        if (ros::Time::isSimTime()) {
          ros::WallDuration(std::min(wait, 0.001)).sleep();
        } else {
          ros::WallDuration(wait).sleep();
        }
        continue;
      }
    }
    // Wait (up to tf_timeout) for the transforms this step needs at exactly its times, so that
    // a replay of the run sees the same frames.
    std::string missing;
    if (!driver_->transformsReady(&missing)) {
      if (tfWaitStart_.isZero()) tfWaitStart_ = ros::WallTime::now();
      if ((ros::WallTime::now() - tfWaitStart_).toSec() < tfTimeout_) {
        lock.unlock();
        ros::WallDuration(0.001).sleep();
        continue;
      }
      ROS_WARN_STREAM_THROTTLE(2.0, "fem_cloth_node: stepping without " << missing
                                        << " (waited tf_timeout = " << tfTimeout_
                                        << " s): using the newest transform; a replay of this "
                                           "run may differ");
    }
    tfWaitStart_ = ros::WallTime();
    if (paused_) --stepRequests_;
    stepOnce();
    if (!driver_->simulator().lastReport().ok) {
      // A failing step leaves the state unchanged: do not spin on it.
      lock.unlock();
      ros::WallDuration(dt).sleep();
    }
  }
  spinner.stop();
}

}  // namespace fem_cloth
