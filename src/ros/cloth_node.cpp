#include "fem_cloth/ros/cloth_node.h"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <ros/names.h>
#include <ros/package.h>
#include <std_msgs/String.h>
#include <rosgraph_msgs/Clock.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/ros/bag_io.h"
#include "fem_cloth/ros/scene_params.h"
#include "fem_cloth/ros/time_checks.h"

namespace fem_cloth {

namespace {

std::string defaultSceneFile() {
  const std::string share = ros::package::getPath("fem_cloth");
  return share.empty() ? std::string() : share + "/config/default_cloth.yaml";
}

// Steps between publications for a rate in Hz (0: every step).
std::uint64_t everyFor(double rate, double dt) {
  if (rate <= 0.0) return 1;
  return std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::llround(1.0 / (rate * dt))));
}

// `v` with `digits` decimals: lags and lengths of time in messages ("12.30", not "12.3012345").
std::string fixedText(double v, int digits) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(digits) << v;
  return out.str();
}

}  // namespace

const std::vector<std::string>& ClothNode::parameterNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> own = {
        "scene_file",   "frame_id",      "time_mode",          "real_time_factor",
        "start_time",   "publish_rate",  "marker_rate",        "publish_velocities",
        "always_publish", "start_paused", "tf_timeout",        "step_lag",
        "replay_bag",   "max_pin_jump",  "max_pending_commands", "command_queue_size",
        "max_failed_attempts", "tf_cache_time", "max_lag", "lag_policy", "frame_wait_timeout",
        "test_step_delay", "replay_mode"};
    own.insert(own.end(), perceptionParameterNames().begin(), perceptionParameterNames().end());
    return own;
  }();
  return names;
}

ClothNode::ClothNode(ros::NodeHandle node, ros::NodeHandle privateNode)
    : node_(node), private_(privateNode) {}

ClothNode::~ClothNode() = default;

bool ClothNode::readParameters(std::string* error) {
  std::string mode = "real_time", replayMode = "play";
  if (!readParam(private_, "replay_mode", replayMode, error, "a string (play or drive)") ||
      !readParam(private_, "frame_id", frame_, error, "a string") ||
      !readParam(private_, "time_mode", mode, error, "a string (real_time or fast)") ||
      !readParam(private_, "real_time_factor", realTimeFactor_, error, "a number") ||
      !readParam(private_, "publish_rate", publishRate_, error, "a number (Hz)") ||
      !readParam(private_, "marker_rate", markerRate_, error, "a number (Hz)") ||
      !readParam(private_, "publish_velocities", publishVelocities_, error, "true or false") ||
      !readParam(private_, "always_publish", alwaysPublish_, error, "true or false") ||
      !readParam(private_, "start_paused", startPaused_, error, "true or false") ||
      !readParam(private_, "tf_timeout", tfTimeout_, error, "a number (s)") ||
      !readParam(private_, "step_lag", stepLag_, error, "a number (s)") ||
      !readParam(private_, "replay_bag", replayBag_, error, "a path") || !readLimits(error)) {
    return false;
  }
  // Times and durations the run loop will compute with: range checked here, so that a value
  // rostime cannot hold stops start-up naming it instead of aborting the node later.
  if (Expected<ros::Duration> lag = checkedDuration(stepLag_, "parameter ~step_lag"); !lag) {
    *error = lag.error();
    return false;
  }
  if (!(stepLag_ >= 0.0)) {
    *error = "parameter ~step_lag must be >= 0 s";
    return false;
  }
  if (!(stepLag_ < maxLag_)) {
    *error = "parameter ~step_lag (" + numberText(stepLag_) + " s) must be below ~max_lag (" + numberText(maxLag_) +
             " s): a lag kept on purpose would pause the node";
    return false;
  }
  if (private_.hasParam("start_time")) {
    double seconds = 0.0;
    if (!private_.getParam("start_time", seconds)) {
      *error = "parameter ~start_time must be a number of seconds >= 0";
      return false;
    }
    Expected<ros::Time> start = checkedTime(seconds, "parameter ~start_time");
    if (!start) {
      *error = start.error();
      return false;
    }
    startTime_ = *start;
    hasStartTime_ = true;
  }
  if (Status s = frameNameProblem(frame_, "~frame_id"); !s) {
    *error = s.error();
    return false;
  }
  if (replayMode != "play" && replayMode != "drive") {
    *error = "parameter ~replay_mode must be play or drive, got '" + printableText(replayMode) + "'";
    return false;
  }
  replayDrive_ = replayMode == "drive";
  if (replayDrive_ && replayBag_.empty()) {
    *error = "parameter ~replay_mode drive replays a recording: give it in ~replay_bag";
    return false;
  }
  if (replayDrive_ && private_.hasParam("time_mode") && mode != "fast") {
    *error = "parameter ~replay_mode drive steps as fast as it can, publishing /clock: ~time_mode must be fast (or "
             "not given), got '" + printableText(mode) + "'";
    return false;
  }
  if (replayDrive_) mode = "fast";
  if (mode == "real_time") {
    timeMode_ = TimeMode::RealTime;
  } else if (mode == "fast") {
    timeMode_ = TimeMode::Fast;
  } else {
    *error = "parameter ~time_mode must be real_time or fast, got '" + mode + "'";
    return false;
  }
  // A factor beyond these is no real time: 1e308 would make every step due at once (fast mode
  // is that, and says so), 1e-300 would never step.
  if (!(realTimeFactor_ >= 0.001 && realTimeFactor_ <= 1000.0)) {
    *error = "parameter ~real_time_factor must be between 0.001 and 1000 (time_mode fast runs as fast as it can), got " +
             numberText(realTimeFactor_);
    return false;
  }
  if (!(publishRate_ >= 0.0) || !(markerRate_ >= 0.0)) {
    *error = "parameters ~publish_rate and ~marker_rate must be >= 0 Hz";
    return false;
  }
  if (Expected<ros::Duration> d = checkedDuration(tfTimeout_, "parameter ~tf_timeout"); !d) {
    *error = d.error();
    return false;
  }
  if (!(tfTimeout_ > 0.0)) {
    *error = "parameter ~tf_timeout must be positive (s)";
    return false;
  }
  return true;
}

bool ClothNode::readLimits(std::string* error) {
  if (!readParam(private_, "max_pin_jump", maxPinJump_, error, "a number (m)") ||
      !readParam(private_, "max_pending_commands", maxPendingCommands_, error, "an integer") ||
      !readParam(private_, "command_queue_size", commandQueueSize_, error, "an integer") ||
      !readParam(private_, "max_failed_attempts", maxFailedAttempts_, error, "an integer") ||
      !readLagLimits(error)) {
    return false;
  }
  if (maxFailedAttempts_ < 1) {
    *error = "parameter ~max_failed_attempts must be >= 1 (attempts at one step), got " +
             std::to_string(maxFailedAttempts_);
    return false;
  }
  if (!(maxPinJump_ > 0.0)) {
    *error = "parameter ~max_pin_jump must be positive (m), got " + numberText(maxPinJump_);
    return false;
  }
  if (maxPendingCommands_ < 1 || commandQueueSize_ < 1) {
    *error = "parameters ~max_pending_commands and ~command_queue_size must be >= 1, got " +
             std::to_string(maxPendingCommands_) + " and " + std::to_string(commandQueueSize_);
    return false;
  }
  return true;
}

bool ClothNode::readLagLimits(std::string* error) {
  std::string policy = "pause";
  if (!readParam(private_, "tf_cache_time", tfCacheTime_, error, "a number (s)") ||
      !readParam(private_, "max_lag", maxLag_, error, "a number (s)") ||
      !readParam(private_, "lag_policy", policy, error, "a string (pause or warn)") ||
      !readParam(private_, "frame_wait_timeout", frameWaitTimeout_, error, "a number (s)") ||
      !readParam(private_, "test_step_delay", testStepDelay_, error, "a number (s)")) {
    return false;
  }
  if (policy != "pause" && policy != "warn") {
    *error = "parameter ~lag_policy must be pause or warn, got '" + policy + "'";
    return false;
  }
  lagPolicyPause_ = policy == "pause";
  for (const auto& [name, value] : {std::make_pair("tf_cache_time", tfCacheTime_), std::make_pair("max_lag", maxLag_),
                                    std::make_pair("frame_wait_timeout", frameWaitTimeout_)}) {
    if (!(value > 0.0) || !checkedDuration(value, name).ok()) {
      *error = std::string("parameter ~") + name + " must be a positive number of seconds, got " + numberText(value);
      return false;
    }
  }
  if (!(testStepDelay_ >= 0.0) || !(testStepDelay_ <= 10.0)) {
    *error = "parameter ~test_step_delay must be between 0 and 10 s, got " + numberText(testStepDelay_);
    return false;
  }
  // A step at a lag below max_lag must find its transforms in tf, with tf_timeout to spare (a
  // frame's newest transform may be that old, and tf prunes from it while the step runs).
  if (!(maxLag_ < tfCacheTime_ - tfTimeout_)) {
    *error = "parameter ~max_lag (" + numberText(maxLag_) + " s) must be below ~tf_cache_time (" +
             numberText(tfCacheTime_) + " s) minus ~tf_timeout (" + numberText(tfTimeout_) +
             " s): tf must still hold the transforms of a step taken that far behind ROS time";
    return false;
  }
  return true;
}

bool ClothNode::takeReplayTime(const RecordedRun& replay, double dt, std::string* error) {
  if (replayDrive_) {
    // The bag's timeline (its states', else from its start), as fem_cloth_sim --commands takes it.
    Expected<Timeline> timeline = replayTimeline(&replay, dt);
    if (!timeline) {
      *error = "~replay_bag: " + timeline.error();
      return false;
    }
    startTime_ = timeline->origin();
    hasStartTime_ = true;
    replayTimeline_ = *timeline;
    if (!replay.frame.empty() && !private_.hasParam("frame_id")) frame_ = replay.frame;
  } else if (!hasStartTime_) {
    if (std::optional<ros::Time> epoch = runEpoch(replay, dt)) {
      if (Expected<ros::Time> t = checkedTime(epoch->toSec(), "the time origin of ~replay_bag"); !t) {
        *error = t.error();
        return false;
      }
      startTime_ = *epoch;
      hasStartTime_ = true;
      replayTimeline_ = runTimeline(replay, dt);  // its pauses too
    }
  }
  return true;
}

bool ClothNode::start(std::string* error) {
  if (!readParameters(error)) return false;
  tfBuffer_ = std::make_unique<tf2_ros::Buffer>(ros::Duration(tfCacheTime_));
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
    doc = storedScene(*replay, ros::this_node::getName());
    if (!doc) {
      *error = "~replay_bag: " + doc.error() + " (~scene_file)";
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
  for (const std::string& w : scene->warnings) ROS_WARN_STREAM("fem_cloth_node: scene: " << w);
  for (const std::string& w : simulation->warnings) ROS_WARN_STREAM("fem_cloth_node: mesh: " << w);

  if (replay && !takeReplayTime(*replay, scene->dt, error)) return false;
  DriverSettings settings;
  settings.frame = frame_;
  settings.tfTimeout = tfTimeout_;
  settings.maxPinJump = maxPinJump_;
  settings.maxPendingCommands = static_cast<std::size_t>(maxPendingCommands_);
  const double dt = scene->dt;
  // replay_mode drive: the frames are the bag's, as fem_cloth_sim --commands reads them.
  const tf2::BufferCore* tf = tfBuffer_.get();
  if (replayDrive_) {
    replayRun_ = std::move(replay);
    replayScene_ = *scene;
    tf = replayRun_->tf.get();
  }
  driver_ = std::make_unique<SimulationDriver>(std::move(simulation).value(), settings, tf, *doc);
  if (replayDrive_ && !openReplay(error)) return false;
  publishEvery_ = everyFor(publishRate_, dt);
  markerEvery_ = everyFor(markerRate_, dt);
  control_ = std::make_unique<RunControl>(startPaused_, dt);
  inbox_ = std::make_unique<CommandInbox>(static_cast<std::size_t>(maxPendingCommands_));
  tfWait_ = std::make_unique<TransformWait>(tfTimeout_, [this](const std::string& frame) {
    return newestTransform(*tfBuffer_, frame_, frame);
  });

  tfIntake_ = std::make_unique<TfIntake>(node_, *tfBuffer_);
  // Perception outputs (perception.h): ~points, ~camera/*, ~marker and tf frames.
  PerceptionSettings perception;
  perception.frame = frame_;
  perception.originFrame = ros::this_node::getName().substr(1);
  perception.alwaysPublish = alwaysPublish_;
  perception.clothFrames = replayBag_.empty();
  if (!readPerceptionParameters(private_, perception, error)) return false;
  Expected<std::unique_ptr<PerceptionOutputs>> outputs =
      PerceptionOutputs::create(private_, *driver_, *scene, *tfBuffer_, std::move(perception));
  if (!outputs) {
    *error = outputs.error();
    return false;
  }
  perception_ = std::move(outputs).value();
  for (const std::string& name : driver_->obstacleNames()) {
    if (Status s = obstacleNameProblem(name); !s) {
      *error = s.error();
      return false;
    }
  }
  refreshObstacleTopics();
  advertise();

  std::ostringstream info;
  const Simulator& sim = driver_->simulator();
  info << "fem_cloth_node: scene '" << scene->name << "' (" << (sourcePath.empty() ? "parameters" : sourcePath)
       << "): " << sim.model().numVertices() << " vertices, " << sim.model().mesh().numTriangles()
       << " triangles, " << scene->materialModel << ", " << sim.integrator().name() << " dt "
       << dt << " s, frame '" << frame_ << "', "
       << (timeMode_ == TimeMode::Fast ? "fast (publishing /clock)" : "real time");
  if (timeMode_ == TimeMode::RealTime && realTimeFactor_ != 1.0) info << " x" << realTimeFactor_;
  if (startPaused_) info << ", paused";
  if (replayDrive_) {
    info << "; replaying '" << replayBag_ << "' (replay_mode drive): " << runReplay_->steps() << " steps, "
         << replayReport_.recordedStates << " recorded states to reproduce";
  }
  ROS_INFO_STREAM(info.str());
  return true;
}

void ClothNode::advertise() {
  meshPub_ = private_.advertise<shape_msgs::Mesh>("mesh", 1, true);
  // Latched: a subscriber that comes late (to a paused node, say) gets the last state at once.
  // replay_mode drive steps as fast as it can: a recorder that falls behind for a while still
  // gets every state.
  const std::uint32_t queue = replayDrive_ ? 1000 : 10;
  statePub_ = private_.advertise<ClothState>("state", queue, true);
  energyPub_ = private_.advertise<ClothEnergy>("energy", queue);
  statsPub_ = private_.advertise<StepStats>("stats", queue);
  pinForcesPub_ = private_.advertise<PinForces>("pin_forces", 10);
  pinWrenchPub_ = private_.advertise<geometry_msgs::WrenchStamped>("pin_wrench", 10);
  diagnosticsPub_ = node_.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 10);
  scenePub_ = private_.advertise<std_msgs::String>("scene", 1, true);
  // Every applied command goes out (a recording replays exactly these), also in the burst after a
  // slow step: as many as may be pending.
  // Each command topic (command_queue.h): its subscriber only hands the command to the inbox.
  forEachCommandType([this](auto type) {
    using C = typename decltype(type)::type;
    const std::string name = CommandTraits<C>::name;
    appliedPubs_.push_back(private_.advertise<C>("applied_" + name, maxPendingCommands_));
    commandSubs_.push_back(private_.subscribe<C>(
        name, commandQueueSize_,
        boost::function<void(const typename C::ConstPtr&)>([this](const typename C::ConstPtr& m) { inbox_->push(*m); })));
  });
  if (timeMode_ == TimeMode::Fast) clockPub_ = node_.advertise<rosgraph_msgs::Clock>("/clock", 10);
  pauseSrv_ = private_.advertiseService("pause", &ClothNode::onPause, this);
  resumeSrv_ = private_.advertiseService("resume", &ClothNode::onResume, this);
  stepSrv_ = private_.advertiseService("step", &ClothNode::onStep, this);
  ros::NodeHandle blocking(private_);
  blocking.setCallbackQueue(&blockingQueue_);
  resetSrv_ = blocking.advertiseService("reset", &ClothNode::onReset, this);
  live_ = std::make_unique<LiveServices>(private_, *inbox_, driver_->document());
  advanceSrv_ = blocking.advertiseService("advance", &ClothNode::onAdvance, this);
}

// --- Callbacks (roscpp's spinner threads): they never touch the simulation ----------------------

bool ClothNode::onReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  res.success = control_->reset();
  res.message = res.success ? "reset to the initial state" : "not reset: the node is shutting down";
  return true;
}

bool ClothNode::onPause(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  res.success = true;
  res.message = control_->pause();
  return true;
}

bool ClothNode::onResume(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  res.success = true;
  res.message = control_->resume();
  return true;
}

bool ClothNode::onStep(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  const Expected<std::string> r = control_->step();
  res.success = r.ok();
  res.message = r ? *r : r.error();
  return true;
}

bool ClothNode::onAdvance(Advance::Request& req, Advance::Response& res) {
  const AdvanceResult r = control_->advance(req.steps);
  res.success = r.success;
  res.message = r.message;
  res.steps_taken = r.stepsTaken;
  res.step = r.step;
  res.time = r.time;
  res.state_hash = r.stateHash;
  return true;
}

// --- The run loop ---------------------------------------------------------------------------------

void ClothNode::takeCommands() {
  std::vector<std::uint64_t> tickets;
  const std::vector<Command> arrived = inbox_->take(&tickets);
  for (std::size_t k = 0; k < arrived.size(); ++k) {
    const Command& c = arrived[k];
    // replay_mode drive: the run is the recording's; a command from outside would make it another.
    const Status s = replayDrive_ ? Status(Error{"the node replays '" + replayBag_ + "' (replay_mode drive): its "
                                                 "commands come from the recording alone"})
                                  : driver_->submit(c, tickets[k]);
    if (!s) reject(topicOf(c), s.error());
    if (!s && tickets[k] != 0) live_->answer(tickets[k], s, c, driver_->stepIndex(), driver_->simulator().time());
  }
  for (CommandTopic topic : commandTopics()) {
    const std::uint64_t refused = inbox_->tally(topic).refused;
    std::uint64_t& told = inboxRefusalsTold_[static_cast<std::size_t>(topic)];
    if (refused == told) continue;
    const std::string capacity = std::to_string(inbox_->capacity());
    reject(topic, std::to_string(refused - told) + " commands refused on arrival: " + capacity +
                      " were already waiting to be checked (max_pending_commands = " + capacity + ")");
    told = refused;
  }
}

void ClothNode::tellTfRefusals() {
  const TfIntake::Refusals refused = tfIntake_->takeRefusals();
  if (refused.count == 0) return;
  lastProblem_ = refused.latest;
  diagnosticsSoon_ = true;
  warn("tf refused", std::to_string(refused.count) + " transform(s) refused, the latest: " + refused.latest,
       "times transforms were refused");
}

void ClothNode::reject(CommandTopic topic, const std::string& why) {
  const std::string kind = std::string("~") + topicName(topic) + " rejected";
  lastProblem_ = kind + ": " + why;
  warn(kind, lastProblem_);
  diagnosticsSoon_ = true;
}

void ClothNode::warn(const std::string& kind, const std::string& message, const std::string& label) {
  const double now = ros::WallTime::now().toSec();
  for (const std::string& line : warnings_.add(kind, message, now, label)) {
    ROS_WARN_STREAM("fem_cloth_node: " << line);
  }
}

void ClothNode::error(const std::string& kind, const std::string& message, const std::string& label) {
  const double now = ros::WallTime::now().toSec();
  for (const std::string& line : errors_.add(kind, message, now, label)) {
    ROS_ERROR_STREAM("fem_cloth_node: " << line);
  }
}

void ClothNode::flushLogs() {
  const double now = ros::WallTime::now().toSec();
  for (const std::string& line : warnings_.flush(now)) ROS_WARN_STREAM("fem_cloth_node: " << line);
  for (const std::string& line : errors_.flush(now)) ROS_ERROR_STREAM("fem_cloth_node: " << line);
}

CommandCounts ClothNode::commandCounts(CommandTopic topic) const {
  return combinedCounts(inbox_->tally(topic), driver_->commandCounts(topic));
}

void ClothNode::restartRealTimeFactorWindow() {
  rtfWindowStart_ = ros::WallTime::now();
  rtfWindowSimStart_ = driver_->simulator().time();
  rtfWindowStepWall_ = 0.0;
}

void ClothNode::doReset() {
  dropServiceCommands("~reset came first");
  driver_->reset();
  clock_ = ros::Time();  // fast mode: /clock starts over with the run
  restartRealTimeFactorWindow();  // a window across the reset measured a negative factor
  tfWait_->clear();
  dueOrigin_ = ros::Time::now().toSec();
  if (replayTimeline_) {
    driver_->setTimeline(*replayTimeline_);
    std::string why;
    if (replayDrive_ && !openReplay(&why)) throw std::runtime_error(why);  // it opened at start-up
  } else if (!hasStartTime_ && timeMode_ == TimeMode::RealTime) {
    driver_->setEpoch(ros::Time::now());
  }
  segmentToAnnounce_ = false;
  clearSelfPause();
  lastReport_ = StepReport();
  publishOutputs(lastReport_, 0.0, true);
  if (replayDrive_) {
    if (Status s = runReplay_->compare(*driver_, replayReport_); !s) throw std::runtime_error(s.error());
  }
  control_->resetDone();
}

void ClothNode::restartRealTime() {
  // ~resume retries the step that stopped the run, and waits for missing frames anew.
  if (selfPause_ != SelfPause::None && lastProblem_ == selfPauseWhy_) {
    lastProblem_ = (selfPause_ == SelfPause::FailingStep ? "resumed after being " : "resumed after: ") + selfPauseWhy_;
  }
  clearSelfPause();
  // Real time restarts from here: the pause is not made up for. A recorder that subscribed
  // while we were paused gets the current state first.
  dueOrigin_ = ros::Time::now().toSec() - driver_->simulator().time() / realTimeFactor_;
  restartRealTimeFactorWindow();  // a window across the pause measured the pause as slowness
  holdOnRosTime();
  publishOutputs(StepReport(), 0.0, true);
  segmentToAnnounce_ = false;
}

void ClothNode::holdOnRosTime() {
  // In fast mode ROS time is the node's own /clock, which a pause stops too; a live replay
  // follows the recording's segments.
  if (timeMode_ != TimeMode::RealTime || replayTimeline_) return;
  if (driver_->stepIndex() == 0) {
    if (!hasStartTime_) driver_->setEpoch(ros::Time::now());  // ~start_time fixes the origin
    return;
  }
  driver_->startSegment(ros::Time::now());
  segmentToAnnounce_ = true;
}

void ClothNode::announceSegment() {
  // A recording must show where the segment starts (runTimeline(), bag_io.h): the state it starts
  // from, with its stamp in it, whatever the publish rate.
  if (!segmentToAnnounce_) return;
  publishOutputs(StepReport(), 0.0, true);
  segmentToAnnounce_ = false;
}

void ClothNode::finishAdvance() {
  // The caller gets the state it stopped at, whatever the publish rate.
  if (driver_->stepIndex() % publishEvery_ != 0) publishOutputs(lastReport_, stepWallTime_, true);
  const State& s = driver_->simulator().state();
  control_->finishAdvance(driver_->stepIndex(), driver_->simulator().time(), stateHash(s.x, s.v));
}

double ClothNode::secondsUntilDue() const {
  // The step that ends at simulation time t + dt is due at dueOrigin + (t + dt) / factor + lag;
  // in a live replay the origin is that of the recorded segment the step is taken in.
  const double dt = driver_->simulator().settings().dt;
  double origin = dueOrigin_;
  if (replayTimeline_) {
    const TimelineSegment& s = driver_->timeline().at(driver_->stepIndex());
    origin = s.stamp.toSec() - (s.step == 0 ? 0.0 : s.time / realTimeFactor_);
  }
  return origin + (driver_->simulator().time() + dt) / realTimeFactor_ + stepLag_ - ros::Time::now().toSec();
}

bool ClothNode::transformsReady() {
  std::vector<std::string> gaveUp;
  switch (tfWait_->check(driver_->framesNotReady(), ros::WallTime::now().toSec(), &gaveUp)) {
    case TransformWait::Verdict::Wait:
      return false;
    case TransformWait::Verdict::TimedOut: {
      std::string frames;
      for (const std::string& f : gaveUp) frames += (frames.empty() ? "'" : ", '") + f + "'";
      warn("tf wait", "stepping without the transforms of frame " + frames + " at exactly the step's "
           "times (waited tf_timeout = " + numberText(tfTimeout_) + " s): using the newest; a "
           "replay of this run may differ. Not waiting for it again until it gets a new transform");
      return true;
    }
    case TransformWait::Verdict::Step:
      break;
  }
  return true;
}

void ClothNode::stepOnce() {
  const ros::WallTime begin = ros::WallTime::now();
  if (testStepDelay_ > 0.0) ros::WallDuration(testStepDelay_).sleep();  // a slow step, for tests
  appliedAtStep_ = driver_->stepIndex();  // the state the due commands take effect in
  appliedAtTime_ = driver_->simulator().time();
  if (replayDrive_) {
    runReplay_->submitDue(*driver_, [this](const Command& c, const Status& s) {
      ++replayReport_.rejected;
      reject(topicOf(c), "a recorded command the replay rejects (as the recorded run did): " + s.error());
    });
    std::string missing;
    if (!driver_->transformsReady(&missing)) {
      warn("replay tf", "step " + std::to_string(driver_->stepIndex() + 1) + ": '" + replayBag_ +
                            "' has no transform for " + missing + "; the newest one is used (as the recorded run did if it did)",
           "similar warnings");
    }
  }
  lastReport_ = driver_->step();
  const StepReport& report = lastReport_;
  stepWallTime_ = (ros::WallTime::now() - begin).toSec();
  publishApplied();
  for (const std::string& w : driver_->takeWarnings()) {
    lastProblem_ = w;
    diagnosticsSoon_ = true;
    warn(WarningThrottle::kindOf(w), w, "similar warnings");
  }
  if (!report.ok) {
    ++failedSteps_;
    lastProblem_ = report.error;
    diagnosticsSoon_ = true;
  } else if (selfPause_ == SelfPause::FailingStep) {
    selfPause_ = SelfPause::None;  // a ~step got past what stopped the run
    selfPauseWhy_.clear();
  }
  // Real-time factor over windows of about a second of wall time. The node cannot keep up when
  // its steps alone take longer than real time allows; a window that is slow because the node
  // waited (for rosbag play to start, for frames, for /clock) is not that.
  rtfWindowStepWall_ += stepWallTime_;
  const double window = (ros::WallTime::now() - rtfWindowStart_).toSec();
  if (window >= 1.0) {
    const double simulated = driver_->simulator().time() - rtfWindowSimStart_;
    realTimeFactorMeasured_ = simulated / window;
    const bool stepsTooSlow = rtfWindowStepWall_ * realTimeFactor_ > simulated;
    restartRealTimeFactorWindow();
    if (timeMode_ == TimeMode::RealTime && !control_->paused() && stepsTooSlow &&
        realTimeFactorMeasured_ < 0.9 * realTimeFactor_) {
      ROS_WARN_STREAM_THROTTLE(5.0, "fem_cloth_node: cannot keep up with real time: real-time factor "
                                        << realTimeFactorMeasured_ << " (a step takes "
                                        << 1e3 * stepWallTime_ << " ms for dt "
                                        << 1e3 * driver_->simulator().settings().dt << " ms)");
    }
  }
  publishClock();
  // replay_mode drive: every recorded state goes out, whatever the publish rate.
  bool recorded = false;
  if (replayDrive_ && report.ok) {
    if (Status s = runReplay_->compare(*driver_, replayReport_); !s) throw std::runtime_error(s.error());
    recorded = runReplay_->recordedStates().count(driver_->stepIndex()) > 0;
  }
  publishOutputs(report, stepWallTime_, recorded);
}

bool ClothNode::openReplay(std::string* error) {
  replayReport_ = BagRunReport();
  replaySummary_.clear();
  Expected<std::unique_ptr<RunReplay>> replay =
      RunReplay::open(&*replayRun_, ros::this_node::getName(), *replayScene_, driver_->timeline(), 0.0,
                      static_cast<std::size_t>(driver_->simulator().model().numVertices()), replayReport_);
  if (!replay) {
    *error = "~replay_bag: " + replay.error();
    return false;
  }
  runReplay_ = std::move(replay).value();
  return true;
}

void ClothNode::endOfReplay(const RunControl::Boundary& b) {
  const std::uint64_t step = driver_->stepIndex();
  const std::string over = "the replay of '" + replayBag_ + "' is over at step " + std::to_string(step) +
                           " (t = " + numberText(driver_->simulator().time()) + " s): ~reset replays it again";
  if (replaySummary_.empty()) {
    const BagRunReport& r = replayReport_;
    replaySummary_ = "replay of '" + replayBag_ + "' done: " + std::to_string(step) + " steps, reproduced " +
                     std::to_string(r.identical) + " of " + std::to_string(r.recordedStates) +
                     " recorded states bit for bit" +
                     (r.firstDifference.empty() ? "" : "; first difference: " + r.firstDifference) +
                     (r.rejected == 0 ? "" : "; " + std::to_string(r.rejected) + " recorded commands rejected");
    if (r.identical == r.recordedStates) {
      ROS_INFO_STREAM("fem_cloth_node: " << replaySummary_ << "; paused (" << over << ")");
    } else {
      lastProblem_ = replaySummary_;
      ROS_WARN_STREAM("fem_cloth_node: " << replaySummary_ << "; paused (" << over << ")");
    }
    publishDiagnostics(true);
  }
  if (b.running) control_->pause();
  if (b.stepWanted && control_->beginStep(driver_->simulator().time() + driver_->simulator().settings().dt)) {
    control_->endStep(step, driver_->simulator().time(), over);
  }
  control_->wait(0.05);
}

void ClothNode::publishApplied() {
  // The commands as they took effect, stamped with their step: what a recording replays.
  bool obstaclesChanged = false;
  for (const Command& c : driver_->takeApplied()) {
    std::visit([this, &c](const auto& command) { appliedPubs_[c.index()].publish(command); }, c);
    live_->applied(c, driver_->document());
    obstaclesChanged = obstaclesChanged || std::holds_alternative<ObstacleCommand>(c);
  }
  if (obstaclesChanged) refreshObstacleTopics();
  // The services' callers, once the document they check the next request against is current.
  for (const SimulationDriver::Outcome& o : driver_->takeOutcomes()) {
    live_->answer(o.ticket, o.status, o.command, appliedAtStep_, appliedAtTime_);
  }
}

void ClothNode::applyWhilePaused() {
  // A paused node applies the services' requests at once: they would take effect before the next
  // step anyway, and their callers do not wait for a ~resume. Commands from the topics wait for
  // the step, as they always did.
  if (!driver_->ticketedDueNow()) return;
  // As before a ~step: a recording shows the segment the commands are stamped in, with the state
  // they take effect in.
  announceSegment();
  appliedAtStep_ = driver_->stepIndex();
  appliedAtTime_ = driver_->simulator().time();
  driver_->applyTicketedNow();
  publishApplied();
  for (const std::string& w : driver_->takeWarnings()) {
    lastProblem_ = w;
    diagnosticsSoon_ = true;
    warn(WarningThrottle::kindOf(w), w, "similar warnings");
  }
}

void ClothNode::dropServiceCommands(const std::string& why) {
  const Status dropped = Error{why + ": dropped before it took effect, nothing changed"};
  for (std::uint64_t ticket : driver_->withdrawTicketed()) {
    live_->answer(ticket, dropped, Command(), driver_->stepIndex(), driver_->simulator().time());
  }
}

void ClothNode::publishClock() {
  if (timeMode_ != TimeMode::Fast) return;
  clock_ = std::max(clock_, driver_->now());
  rosgraph_msgs::Clock clock;
  clock.clock = clock_;
  clockPub_.publish(clock);
  lastClock_ = ros::WallTime::now();
}

void ClothNode::clockToStepEnd() {
  if (timeMode_ != TimeMode::Fast) return;
  const ros::Time end = driver_->stampOf(driver_->simulator().time() + driver_->simulator().settings().dt);
  if (end <= clock_) return;  // announced already: keepClockGoing() repeats it
  clock_ = end;
  publishClock();
}

void ClothNode::keepClockGoing() {
  // As Gazebo does while paused: a node on simulation time that starts (or subscribes) later gets
  // a time within 0.1 s, and tf publishers on it (robot_state_publisher) start.
  if (timeMode_ == TimeMode::Fast && (ros::WallTime::now() - lastClock_).toSec() >= 0.1) publishClock();
}

double ClothNode::lag() const {
  if (timeMode_ != TimeMode::RealTime) return 0.0;
  return secondsBetween(ros::Time::now(), driver_->now());
}

std::vector<std::string> ClothNode::followedFrames() const {
  std::vector<std::string> frames = driver_->pins().frames();
  if (const ObstacleSet* obstacles = driver_->simulator().obstacles()) {
    for (std::size_t k = 0; k < obstacles->size(); ++k) {
      const std::string& f = (*obstacles)[k].frame;
      if (!f.empty() && std::find(frames.begin(), frames.end(), f) == frames.end()) frames.push_back(f);
    }
  }
  return frames;
}

bool ClothNode::lagAllowsStep() {
  // A live replay keeps the recording's times: its lag is reported, not acted on.
  if (timeMode_ != TimeMode::RealTime || replayTimeline_) return true;
  const double behind = lag(), wall = tfCacheTime_ - tfTimeout_;
  const std::string where = "the node is " + fixedText(behind, 2) + " s behind ROS time; tf keeps " +
                            numberText(tfCacheTime_) + " s (tf_cache_time)";
  if (behind > maxLag_ && lagPolicyPause_) {
    pauseBecause(where + ", and max_lag is " + numberText(maxLag_) + " s (lag_policy pause)", SelfPause::Lag);
    return false;
  }
  if (behind > wall) {
    const std::vector<std::string> frames = followedFrames();
    if (!frames.empty()) {
      pauseBecause(where + ": the transforms of frame '" + frames.front() + "' for its next step would be gone "
                   "within tf_timeout (lag_policy warn pauses at tf_cache_time - tf_timeout = " + numberText(wall) +
                   " s rather than step with another time's transforms)", SelfPause::Lag);
      return false;
    }
  }
  if (behind > maxLag_) {
    lastProblem_ = where + ", more than max_lag = " + numberText(maxLag_) + " s (lag_policy warn)";
    diagnosticsSoon_ = true;
    warn("lag", lastProblem_, "lag warnings");
  }
  return true;
}

void ClothNode::pauseItself(SelfPause cause, const std::string& why) {
  control_->pause();
  dropServiceCommands("the node paused itself (" + why + ")");
  selfPause_ = cause;
  selfPauseWhy_ = why;
  lastProblem_ = why;
  publishDiagnostics(true);
}

void ClothNode::clearSelfPause() {
  selfPause_ = SelfPause::None;
  selfPauseWhy_.clear();
  frameWaitSince_.reset();  // a new wait of frame_wait_timeout
  failedAttempts_ = 0;
}

void ClothNode::pauseBecause(const std::string& why, SelfPause cause) {
  pauseItself(cause, why);
  ROS_WARN_STREAM("fem_cloth_node: paused: " << why << ". The state stays at step " << driver_->stepIndex()
                  << " (t = " << numberText(driver_->simulator().time()) << " s); ~resume goes on from ROS "
                  "time now (what the node fell behind is not made up for), ~reset starts over");
}

bool ClothNode::followedFramesArrived() {
  framesWaitedFor_.clear();
  for (const std::string& f : followedFrames()) {
    if (!newestTransform(*tfBuffer_, frame_, f)) framesWaitedFor_.push_back(f);
  }
  if (framesWaitedFor_.empty()) {
    // In real_time mode the run starts now, not when the node began to wait (which would count
    // as lag).
    if (frameWaitSince_ && timeMode_ == TimeMode::RealTime && !replayTimeline_) {
      if (!hasStartTime_) driver_->setEpoch(ros::Time::now());
      dueOrigin_ = ros::Time::now().toSec();
      restartRealTimeFactorWindow();
    }
    frameWaitSince_.reset();
    return true;
  }
  std::string names;
  for (const std::string& f : framesWaitedFor_) names += (names.empty() ? "'" : ", '") + f + "'";
  const ros::WallTime now = ros::WallTime::now();
  if (!frameWaitSince_) {
    frameWaitSince_ = now;
    ROS_INFO_STREAM("fem_cloth_node: waiting up to " << numberText(frameWaitTimeout_) << " s (frame_wait_timeout) "
                    "for the tf frames the scene follows before the first step: " << names);
  }
  if ((now - *frameWaitSince_).toSec() < frameWaitTimeout_) return false;
  pauseBecause("no transform of frame(s) " + names + ", which the scene follows, came within frame_wait_timeout = " +
               numberText(frameWaitTimeout_) + " s before the first step (is their publisher running" +
               std::string(timeMode_ == TimeMode::Fast ? ", on this node's /clock" : "") +
               "?): not stepping without them; publish them and call ~resume", SelfPause::Frames);
  return false;
}

void ClothNode::publishOutputs(const StepReport& report, double wallTime, bool force) {
  const std::uint64_t step = driver_->stepIndex();
  // Never the same state twice (the same step at the same stamp: a failed attempt, a ~resume in
  // fast mode): the latched one is there for whoever subscribes later.
  const bool stateDue = (force || step % publishEvery_ == 0) && publishedState_ != std::make_pair(step, driver_->now());
  const bool markerDue = force || step % markerEvery_ == 0;
  if (stateDue) {
    const Simulator& sim = driver_->simulator();
    statePub_.publish(toMsg(driver_->header(), sim.state(), sim.dim(), publishVelocities_));
    publishedState_ = std::make_pair(step, driver_->now());
    if (wanted(energyPub_)) energyPub_.publish(toMsg(driver_->header(), driver_->stepIndex(), driver_->simulator().energies()));
    if (wanted(statsPub_)) {
      statsPub_.publish(statsMessage(*driver_, report, wallTime, realTimeFactorMeasured_,
                                     [this](CommandTopic topic) { return commandCounts(topic); }));
    }
    publishPinReactions();
    bool wrenchWanted = false;
    for (const ros::Publisher& pub : obstacleWrenchPubs_) wrenchWanted = wrenchWanted || wanted(pub);
    if (wrenchWanted && sim.obstacles() != nullptr) {
      const std::vector<geometry_msgs::WrenchStamped> wrenches = obstacleWrenches(driver_->header(), *sim.obstacles());
      for (std::size_t k = 0; k < wrenches.size() && k < obstacleWrenchPubs_.size(); ++k) {
        obstacleWrenchPubs_[k].publish(wrenches[k]);
      }
    }
  }
  if (markerDue && obstacleMarkerPub_ && wanted(obstacleMarkerPub_) && driver_->simulator().obstacles()) {
    obstacleMarkerPub_.publish(obstacleMarkers(driver_->header(), *driver_->simulator().obstacles()));
  }
  perception_->publish(stateDue, markerDue);
  publishDiagnostics(false);
}

void ClothNode::publishPinReactions() {
  // One wrench topic per grasp frame (and one for the pins fixed in the simulation frame),
  // advertised as soon as a pin follows the frame, so that a client can subscribe before it pulls.
  std::vector<std::string> grasps = driver_->pins().frames();
  if (!driver_->simulator().pinnedVertices().empty()) grasps.push_back(frame_);
  bool graspWanted = false;
  for (const std::string& frame : grasps) {
    auto it = graspWrenchPubs_.find(tfFrameName(frame));
    if (it == graspWrenchPubs_.end()) {
      it = graspWrenchPubs_.emplace(tfFrameName(frame), private_.advertise<geometry_msgs::WrenchStamped>(
                                                            graspWrenchTopic(frame), 10)).first;
    }
    graspWanted = graspWanted || wanted(it->second);
  }
  const bool forces = wanted(pinForcesPub_), wrenches = wanted(pinWrenchPub_) || graspWanted;
  if (!forces && !wrenches) return;
  // One copy of the reactions for every message.
  const Simulator& sim = driver_->simulator();
  const VectorX reactions = sim.pinReactions();
  if (forces) pinForcesPub_.publish(toMsg(driver_->header(), sim.pinnedVertices(), reactions, sim.dim()));
  if (!wrenches) return;
  for (const GraspWrench& w : driver_->graspWrenches(reactions)) {
    const geometry_msgs::WrenchStamped msg = toMsg(driver_->header(), w);
    if (wanted(pinWrenchPub_)) pinWrenchPub_.publish(msg);
    auto it = graspWrenchPubs_.find(tfFrameName(w.frame));
    if (it != graspWrenchPubs_.end() && wanted(it->second)) it->second.publish(msg);
  }
}

void ClothNode::refreshObstacleTopics() {
  // Only when the scene has obstacles: a scene pays for what it declares.
  const std::vector<std::string> names = driver_->obstacleNames();
  if (!names.empty() && !obstacleMarkerPub_) {
    obstacleMarkerPub_ = private_.advertise<visualization_msgs::MarkerArray>("obstacle_markers", 2, true);
  }
  std::vector<ros::Publisher> pubs;
  for (const std::string& name : names) {
    pubs.push_back(private_.advertise<geometry_msgs::WrenchStamped>("obstacles/" + name + "/wrench", 10));
  }
  obstacleWrenchPubs_.swap(pubs);  // the new ones first: a kept topic stays advertised
  if (!obstacleMarkerPub_) return;
  // Latched: RViz started later, or a paused node, still shows where the obstacles are; a
  // removed one is deleted.
  visualization_msgs::MarkerArray markers;
  visualization_msgs::Marker clear;
  clear.action = visualization_msgs::Marker::DELETEALL;
  clear.ns = "obstacles";
  markers.markers.push_back(clear);
  if (const ObstacleSet* obstacles = driver_->simulator().obstacles()) {
    for (const auto& m : obstacleMarkers(driver_->header(), *obstacles).markers) markers.markers.push_back(m);
  }
  obstacleMarkerPub_.publish(markers);
}

void ClothNode::publishDiagnostics(bool force) {
  const ros::WallTime now = ros::WallTime::now();
  const double since = (now - lastDiagnostics_).toSec();
  if (!force && since < 1.0 && !(diagnosticsSoon_ && since >= 0.1)) return;
  lastDiagnostics_ = now;
  diagnosticsSoon_ = false;
  diagnostic_msgs::DiagnosticArray array;
  array.header.stamp = driver_->now();
  diagnostic_msgs::DiagnosticStatus status;
  status.name = ros::this_node::getName();
  status.hardware_id = "fem_cloth";
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
  std::uint64_t rejected = 0;
  for (CommandTopic topic : commandTopics()) {
    const CommandCounts c = commandCounts(topic);
    const std::string name = std::string("~") + topicName(topic) + " commands ";
    add(name + "received", std::to_string(c.received));
    add(name + "rejected", std::to_string(c.rejected));
    add(name + "applied", std::to_string(c.applied));
    add(name + "pending", std::to_string(c.pending));
    add(name + "discarded by ~reset", std::to_string(c.discarded));
    rejected += c.rejected;
  }
  add("rejected commands", std::to_string(rejected));
  add("failed steps", std::to_string(failedSteps_));
  add("paused", control_->paused() ? "true" : "false");
  // The run's energy balance, judged as fem_cloth_sim's summaries judge it (judgeBalance).
  Simulator& sim = driver_->simulator();
  const EnergyReport energies = sim.energies();
  const BalanceJudgement balance = sim.balance(energies);
  add("energy balance error (J)", std::to_string(energies.balanceError));
  add("energy balance", balance.text());
  add("pin jumps", std::to_string(energies.pinJumps));
  if (!balance.ok()) status.message = balance.warning();
  // How deep the surface reached into a box between the vertices (fem_cloth_sim warns the same).
  const SimulationDriver::BoxDepth& deepest = driver_->deepestIntoBox();
  for (const auto& [key, value] : boxDepthDiagnostics(deepest)) add(key, value);
  const std::string intoBox = boxDepthWarning(deepest);
  if (!intoBox.empty() && status.message == "running") status.message = intoBox;
  add("paused by a failing step", selfPause_ == SelfPause::FailingStep ? "true" : "false");
  // The lag and how far back tf reaches (docs/node.md, Robot in the loop).
  add("lag (s)", fixedText(lag(), 3));
  add("tf cache (s)", numberText(tfCacheTime_));
  add("max lag (s)", numberText(maxLag_));
  add("lag policy", lagPolicyPause_ ? "pause" : "warn");
  add("paused by lag", selfPause_ == SelfPause::Lag ? "true" : "false");
  std::string waiting;
  for (const std::string& f : framesWaitedFor_) waiting += (waiting.empty() ? "" : " ") + f;
  add("waiting for frames", waiting);
  if (replayDrive_) {
    add("replay: recorded states reproduced bit for bit",
        std::to_string(replayReport_.identical) + " of " + std::to_string(replayReport_.compared) + " compared (" +
            std::to_string(replayReport_.recordedStates) + " recorded)");
    add("replay: steps", std::to_string(driver_->stepIndex()) + " of " + std::to_string(runReplay_->steps()));
    if (!replayReport_.firstDifference.empty()) add("replay: first difference", replayReport_.firstDifference);
  }
  if (selfPause_ != SelfPause::None) status.message = selfPauseWhy_;
  status.level = failedSteps_ > 0 ? diagnostic_msgs::DiagnosticStatus::ERROR
                 : (rejected > 0 || !lastProblem_.empty() || !balance.ok() || !intoBox.empty() ||
                    selfPause_ != SelfPause::None)
                     ? diagnostic_msgs::DiagnosticStatus::WARN
                     : diagnostic_msgs::DiagnosticStatus::OK;
  array.status.push_back(status);
  diagnosticsPub_.publish(array);
}

void ClothNode::waitForRosTime() {
  // With use_sim_time, ROS time is zero until the first /clock. A /use_sim_time left true by an
  // earlier replay (or a rosbag play started without --clock) would make the node wait in
  // silence: say once what it waits for.
  constexpr double kSilentWait = 5.0;  // s of wall time: replay.launch's rosbag play waits 2 s
  const ros::WallTime since = ros::WallTime::now();
  bool told = false;
  while (ros::ok() && ros::Time::now().isZero()) {
    if (!told && ros::Time::isSimTime() && (ros::WallTime::now() - since).toSec() >= kSilentWait) {
      ROS_WARN_STREAM("fem_cloth_node: /use_sim_time is true and nothing has come on /clock for "
                      << kSilentWait << " s: waiting for /clock before the first step (left over "
                      "from a replay? `rosparam set /use_sim_time false` and restart for real time)");
      told = true;
    }
    ros::WallDuration(0.001).sleep();
  }
}

void ClothNode::begin() {
  // Time origin: wait for a valid ROS time (with use_sim_time, the first /clock).
  if (timeMode_ == TimeMode::RealTime) waitForRosTime();
  const ros::Time now = ros::Time::now();
  const ros::Time epoch =
      hasStartTime_ ? startTime_ : (timeMode_ == TimeMode::Fast ? ros::Time(0) : now);
  driver_->setEpoch(epoch);
  if (replayTimeline_) driver_->setTimeline(*replayTimeline_);
  dueOrigin_ = (hasStartTime_ && timeMode_ == TimeMode::RealTime ? epoch : now).toSec();
  restartRealTimeFactorWindow();
  meshPub_.publish(toMsg(driver_->simulator().model().mesh()));
  // Latched: RViz started later, or a paused node, still shows where the obstacles are.
  if (obstacleMarkerPub_) obstacleMarkerPub_.publish(obstacleMarkers(driver_->header(), *driver_->simulator().obstacles()));
  std_msgs::String sceneMsg;
  sceneMsg.data = sceneText_;
  scenePub_.publish(sceneMsg);
  publishClock();
  publishOutputs(StepReport(), 0.0, true);
  if (replayDrive_) {
    if (Status s = runReplay_->compare(*driver_, replayReport_); !s) throw std::runtime_error(s.error());
  }
}

void ClothNode::turn() {
  keepClockGoing();
  // Commands that arrived before a ~reset are dropped by it: take them first.
  takeCommands();
  tellTfRefusals();
  flushLogs();
  const RunControl::Boundary b = control_->boundary();
  if (b.advanceEnded) finishAdvance();
  if (b.reset) {
    takeCommands();  // those that came in since the first look are older than the reset too
    doReset();
  }
  if (b.resumed) restartRealTime();
  if (!b.running && !b.stepWanted) {
    // While paused the state's simulation time is held at ROS time now (a node paused from the
    // start: its time origin; later: a new segment of the timeline, as ~resume starts one), so
    // that a pin or grasp in a moving frame is checked against the frame as it is now, not as it
    // was when the pause began (refused as 'unknown at the time it is needed' after a pause
    // longer than tf_timeout). Not once a step is wanted: the step's times must not move while it
    // waits for their transforms.
    holdOnRosTime();
    applyWhilePaused();
    publishDiagnostics(false);
    control_->wait(0.05);
    return;
  }
  if (replayDrive_ && driver_->stepIndex() >= runReplay_->steps()) {
    endOfReplay(b);
    return;
  }
  if (b.running && timeMode_ == TimeMode::RealTime) {
    const double wait = secondsUntilDue();
    if (wait > 0.0) {
      // On simulation time, ROS time moves in jumps of /clock: look again soon.
      control_->wait(std::min(wait, ros::Time::isSimTime() ? 0.001 : 0.05));
      return;
    }
  }
  // Not a step (before the first) without the frames the scene follows, nor with transforms tf no
  // longer holds. The wait for the frames first: in real_time mode the run's time starts when they
  // come, so the wait is not lag (the lag check first paused a node waiting for a frame after
  // max_lag, blaming the lag). (replay_mode drive: the frames are the recording's, which has what
  // it has.)
  if ((!replayDrive_ && driver_->stepIndex() == 0 && !followedFramesArrived()) || (b.running && !lagAllowsStep())) {
    publishDiagnostics(false);
    control_->wait(0.01);
    return;
  }
  // Wait (up to tf_timeout) for the transforms this step needs at exactly its times, so that a
  // replay of the run sees the same frames; in lock-step, once /clock has reached them.
  clockToStepEnd();
  if (!replayDrive_ && !transformsReady()) {
    control_->wait(0.001);
    return;
  }
  const double dt = driver_->simulator().settings().dt;
  if (!control_->beginStep(driver_->simulator().time() + dt)) return;
  announceSegment();
  stepOnce();
  control_->endStep(driver_->stepIndex(), driver_->simulator().time(),
                    lastReport_.ok ? std::string() : lastReport_.error);
  if (lastReport_.ok) {
    failedAttempts_ = 0;
  } else if (!b.running) {
    // A ~step or ~advance while paused: its caller hears of it; no retry follows.
    error(WarningThrottle::kindOf(lastReport_.error), lastReport_.error, "failed steps");
  } else if (!countFailedAttempt()) {
    // A failing step leaves the state unchanged: do not spin on it.
    control_->wait(dt);
  }
}

bool ClothNode::countFailedAttempt() {
  if (replayTimeline_ && !replayDrive_) {
    // A live replay retries until the recorded commands that got the recorded run past this
    // step come (a ~remove_obstacle, say, made while the recorded run was paused).
    error(WarningThrottle::kindOf(lastReport_.error), lastReport_.error, "failed steps");
    return false;
  }
  if (++failedAttempts_ == 1) {
    warn("failed attempt", lastReport_.error + "; retrying the step, up to " +
         std::to_string(maxFailedAttempts_) + " attempts in all (max_failed_attempts)", "failed attempts");
  }
  if (failedAttempts_ < maxFailedAttempts_) return false;
  stopOnFailure();
  return true;
}

void ClothNode::stopOnFailure() {
  const std::uint64_t step = driver_->stepIndex();
  // The last good state (a failed step leaves it as it was), unless it went out already.
  publishOutputs(StepReport(), 0.0, true);
  pauseItself(SelfPause::FailingStep, "paused after " + std::to_string(failedAttempts_) +
                                          " failed attempts at the same step (max_failed_attempts): " + lastReport_.error);
  failedAttempts_ = 0;
  ROS_ERROR_STREAM("fem_cloth_node: " << selfPauseWhy_ << ". The state stays at step " << step
                   << " (t = " << numberText(driver_->simulator().time())
                   << " s), published on ~state. To go on, remove the cause (an obstacle in the "
                      "cloth: ~remove_obstacle or ~move_obstacle; a pin: release or move it) and "
                      "call ~resume to retry the step, or ~reset to start over");
}

void ClothNode::run() {
  ros::AsyncSpinner spinner(2);                           // commands and the quick services
  ros::AsyncSpinner blockingSpinner(2, &blockingQueue_);  // ~advance and ~reset
  spinner.start();
  blockingSpinner.start();
  // However run() ends (shutdown, or an exception): the services waiting for it answer.
  struct Stop {
    RunControl& control;
    ~Stop() { control.shutdown(); }
  } stop{*control_};
  begin();
  while (ros::ok()) turn();
}

}  // namespace fem_cloth
