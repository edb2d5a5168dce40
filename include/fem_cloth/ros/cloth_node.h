// fem_cloth_node: steps a cloth scene and serves it to ROS. A thin adapter over
// SimulationDriver: it reads parameters, wires topics and services, keeps time and publishes.
//
// Private parameters (beside the scene keys, see docs/scenes.md):
//   scene_file        string  a scene YAML (default: the package's config/default_cloth.yaml
//                             when no scene key is set under ~)
//   frame_id          string  simulation frame ("world")
//   time_mode         string  real_time: step in step with ROS time (wall clock, or /clock with
//                             use_sim_time) scaled by real_time_factor; fast: as fast as
//                             possible, publishing /clock (for use_sim_time listeners)
//   real_time_factor  double  simulated seconds per second in real_time mode (1.0)
//   start_time        double  ROS time (s) of simulation time 0 (default: now in real_time
//                             mode, 0 in fast mode)
//   publish_rate      double  Hz of ~state, ~energy, ~stats and pin reactions (30; 0: every step)
//   marker_rate       double  Hz of ~marker (10)
//   publish_velocities bool   fill ClothState.velocities (false)
//   always_publish    bool    compute energies, markers and reactions even with no subscriber
//   start_paused      bool    wait for ~resume or ~step (false)
//   tf_timeout        double  s after which a frame's newest transform counts as stale (1.0)
//   step_lag          double  s the node stays behind ROS time in real_time mode, so that the
//                             commands and transforms for a step have arrived when it is taken:
//                             what makes a live replay reproduce a recording (0)
//   replay_bag        string  a recorded run: its scene (unless one is given) and its timeline
//                             (start_time and the segments its pauses began, timeline.h) are
//                             used, for replaying it live
//   replay_mode       string  play: the commands and frames come from rosbag play (replay.launch),
//                             on its /clock; drive: the node reads them from replay_bag itself and
//                             steps in lock-step with the bag as fast as it can, publishing /clock
//                             (time_mode fast), so that every recorded state is reproduced however
//                             slow the machine; it pauses at the end of the recording, saying how
//                             many recorded states it reproduced bit for bit (play)
//   max_pin_jump      double  m: a pin target farther than this from its vertex is refused (1.0)
//   max_pending_commands int  commands that may wait to be checked, and checked ones that may
//                             wait for their stamp; more are refused (10000)
//   command_queue_size int    roscpp subscriber queue of ~pin and ~force (1000)
//   max_failed_attempts int   failed attempts at one step after which a running node pauses
//                             itself and says why (10; not in a live replay)
//   tf_cache_time     double  s of transforms the tf buffer keeps per frame (30)
//   max_lag           double  s the node may be behind ROS time in real_time mode (lag: ROS now
//                             minus the stamp of its state) before lag_policy applies (10); must
//                             be below tf_cache_time - tf_timeout
//   lag_policy        string  pause: pause the node when the lag passes max_lag; warn: warn, and
//                             pause only when the lag reaches tf_cache_time - tf_timeout while
//                             the scene follows tf frames (the transforms its steps need would be
//                             gone). Either way no step uses a transform tf no longer holds
//   frame_wait_timeout double s of wall time the node waits, before its first step, for the tf
//                             frames its scene follows (obstacles' and pins' frames); then it
//                             pauses, naming the missing ones (30)
//   test_step_delay   double  s of wall time slept in each step: for tests that need a node that
//                             falls behind (0)
// and the perception parameters (point cloud, camera, tf frames, marker look: perception.h).
//
// Threads: roscpp's spinners run the callbacks, which only hand commands to a CommandInbox and
// requests to a RunControl; the run loop (run()) is the one thread that touches the simulation.
#pragma once

#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>

#include <array>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "fem_cloth/Advance.h"
#include "fem_cloth/ros/bag_replay.h"
#include "fem_cloth/ros/command_queue.h"
#include "fem_cloth/ros/live_services.h"
#include "fem_cloth/ros/perception.h"
#include "fem_cloth/ros/run_control.h"
#include "fem_cloth/ros/simulation_driver.h"
#include "fem_cloth/ros/tf_intake.h"
#include "fem_cloth/ros/transform_wait.h"
#include "fem_cloth/ros/warning_throttle.h"

namespace fem_cloth {

class ClothNode {
 public:
  ClothNode(ros::NodeHandle node, ros::NodeHandle privateNode);
  ~ClothNode();

  /// Reads the parameters and builds the simulation. On a missing or invalid parameter (or
  /// scene) returns false with one line naming it.
  bool start(std::string* error);
  /// Steps and publishes until ROS shuts down. Throws only on an internal failure of the
  /// simulation (the node's main exits with status 3).
  void run();

  /// The names of the node's own private parameters (everything else under ~ is scene).
  static const std::vector<std::string>& parameterNames();

 private:
  enum class TimeMode { RealTime, Fast };

  bool readParameters(std::string* error);
  bool readLimits(std::string* error);
  /// tf_cache_time, max_lag, lag_policy, frame_wait_timeout, test_step_delay.
  bool readLagLimits(std::string* error);
  void advertise();
  bool onReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  bool onPause(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  bool onResume(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  bool onStep(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  bool onAdvance(Advance::Request& req, Advance::Response& res);

  // --- The run loop (one thread) ---------------------------------------------------------------
  /// Publishes what a starting node publishes once (mesh, scene, the initial state).
  void begin();
  /// One pass: commands, requests, and a step when one is due.
  void turn();
  /// Hands the commands that arrived to the driver (it validates and queues them).
  void takeCommands();
  void reject(CommandTopic topic, const std::string& why);
  /// Says which transforms the tf intake refused since the last turn.
  void tellTfRefusals();
  /// ~reset, ~resume and the end of an ~advance, as the run loop carries them out.
  void doReset();
  void restartRealTime();
  /// Paused (and on ~resume): the current state is held at ROS time now (timeline.h).
  void holdOnRosTime();
  /// Before the first step of a new segment: its first state, with its new stamp.
  void announceSegment();
  void waitForRosTime();
  void finishAdvance();
  /// Seconds until the next step is due in real_time mode (<= 0: due).
  double secondsUntilDue() const;
  /// False while the node waits (up to tf_timeout) for the transforms the next step needs.
  bool transformsReady();
  /// One step and its outputs.
  void stepOnce();
  /// replay_mode drive: the replay of replay_bag from its start (at start-up and ~reset).
  bool openReplay(std::string* error);
  /// The run's time origin and timeline from ~replay_bag (start()): the recording's states' in
  /// replay_mode drive, else its epoch and pauses unless a start time was given.
  bool takeReplayTime(const RecordedRun& replay, double dt, std::string* error);
  /// replay_mode drive, at the end of the recording: says once how the replay went, pauses, and
  /// answers a ~step or ~advance that the replay is over.
  void endOfReplay(const RunControl::Boundary& b);
  /// Publishes the commands the driver applied on ~applied_<topic>, and answers the services'
  /// callers waiting for them (applied in the state of appliedAtStep_).
  void publishApplied();
  /// A paused node: applies the services' requests due now, without a step.
  void applyWhilePaused();
  /// The services' commands still pending are dropped (a self-pause, a ~reset): their callers
  /// hear `why`.
  void dropServiceCommands(const std::string& why);
  /// After a step taken while running: counts a failed attempt at the same step (warning on the
  /// first); true when the node has paused itself, at max_failed_attempts (stopOnFailure()).
  bool countFailedAttempt();
  /// Pauses the node on the step that keeps failing: the last good state out, an ERROR on
  /// /diagnostics with the cause, one ERROR line saying how to go on.
  void stopOnFailure();
  /// /clock at the simulation time (fast mode only), or where clockToStepEnd() took it, if later:
  /// /clock never goes back within a run (~reset starts it over).
  void publishClock();
  /// Lock-step (fast mode): /clock at the end of the step about to be taken, before the node
  /// waits for that step's transforms, which a robot stack on simulation time publishes only once
  /// /clock has reached their time.
  void clockToStepEnd();
  /// In fast mode, /clock again (same time) when none went out for 0.1 s of wall time: while
  /// paused or waiting, so that nodes on simulation time started later get a time.
  void keepClockGoing();
  /// The lag (s): ROS now minus the stamp of the current state, in real_time mode (0 in fast mode,
  /// where the node makes ROS time).
  double lag() const;
  /// Applies lag_policy before a step while running in real_time mode; false when it paused.
  bool lagAllowsStep();
  /// Why the node paused itself, if it did: a step that kept failing, the lag, or the frames
  /// the scene follows missing before the first step.
  enum class SelfPause { None, FailingStep, Lag, Frames };
  /// Pauses the node by itself for `cause`, `why` on /diagnostics at once (the caller logs).
  void pauseItself(SelfPause cause, const std::string& why);
  /// Pauses the node by itself for its lag or for missing frames, and says why in one line.
  void pauseBecause(const std::string& why, SelfPause cause);
  /// Forgets why the node paused itself, and the attempts and frame wait behind it (~resume, ~reset).
  void clearSelfPause();
  /// The tf frames the scene follows now: those of obstacles and of frame-following pins.
  std::vector<std::string> followedFrames() const;
  /// Before the first step: false while a followed frame has no transform in tf (pausing with
  /// their names after frame_wait_timeout).
  bool followedFramesArrived();
  /// The real-time factor is measured from here (start, reset, resume, each ~1 s window).
  void restartRealTimeFactorWindow();
  void publishOutputs(const StepReport& report, double wallTime, bool force);
  /// ~pin_forces, ~pin_wrench and ~grasp/<frame>/wrench, from one copy of the pin reactions.
  void publishPinReactions();
  /// ~obstacles/<name>/wrench and ~obstacle_markers for the obstacles there are now.
  void refreshObstacleTopics();
  /// At least once a second; within 0.1 s after a problem (at most 10 per second).
  void publishDiagnostics(bool force);
  CommandCounts commandCounts(CommandTopic topic) const;
  /// Log lines through the throttles (warnings; errors); `label` names the kind in summaries.
  void warn(const std::string& kind, const std::string& message, const std::string& label = "");
  void error(const std::string& kind, const std::string& message, const std::string& label = "");
  void flushLogs();
  bool wanted(const ros::Publisher& pub) const {
    return alwaysPublish_ || pub.getNumSubscribers() > 0;
  }

  ros::NodeHandle node_, private_;
  // ~advance and ~reset wait for the run loop: their own queue and spinner, so that waiting
  // never holds up commands, ~pause or ~resume.
  ros::CallbackQueue blockingQueue_;
  std::unique_ptr<tf2_ros::Buffer> tfBuffer_;  // made when the parameters are read: tf_cache_time
  std::unique_ptr<TfIntake> tfIntake_;
  std::unique_ptr<SimulationDriver> driver_;
  std::unique_ptr<PerceptionOutputs> perception_;  // ~points, ~camera/*, ~marker, tf frames
  std::unique_ptr<RunControl> control_;
  std::unique_ptr<CommandInbox> inbox_;
  std::unique_ptr<TransformWait> tfWait_;
  WarningThrottle warnings_, errors_;

  // Parameters.
  std::string frame_ = "world";
  TimeMode timeMode_ = TimeMode::RealTime;
  double realTimeFactor_ = 1.0;
  double publishRate_ = 30.0, markerRate_ = 10.0;
  bool publishVelocities_ = false, alwaysPublish_ = false, startPaused_ = false;
  double tfTimeout_ = 1.0;
  bool hasStartTime_ = false;
  ros::Time startTime_;  // exact: a time origin from a bag must not pass through a double
  double stepLag_ = 0.0;
  std::string replayBag_;
  std::optional<Timeline> replayTimeline_;  // the recorded run's, replayed live
  bool replayDrive_ = false;                // replay_mode drive
  std::optional<RecordedRun> replayRun_;    // replay_mode drive: the run (its tf is the driver's)
  std::optional<Scene> replayScene_;        // and the scene it is replayed on
  std::unique_ptr<RunReplay> runReplay_;    // and its commands, length and recorded states
  BagRunReport replayReport_;               // what the replay reproduced so far
  std::string replaySummary_;               // said at its end (empty before)
  double maxPinJump_ = 1.0;
  int maxPendingCommands_ = 10000, commandQueueSize_ = 1000;
  int maxFailedAttempts_ = 10;
  double tfCacheTime_ = 30.0, maxLag_ = 10.0, frameWaitTimeout_ = 30.0, testStepDelay_ = 0.0;
  bool lagPolicyPause_ = true;  // lag_policy: pause (true) or warn

  // Run state (the run loop's).
  std::uint64_t publishEvery_ = 1, markerEvery_ = 1;
  // ROS time (s) at which simulation time 0 is due in real_time mode. A double, not a ros::Time:
  // after a pause it may lie before ROS time 0 (simulation time ahead of a sim clock).
  double dueOrigin_ = 0.0;
  bool segmentToAnnounce_ = false;
  ros::WallTime rtfWindowStart_;
  double rtfWindowSimStart_ = 0.0, realTimeFactorMeasured_ = 0.0;
  double rtfWindowStepWall_ = 0.0;  // s of wall time the window's steps took themselves
  double stepWallTime_ = 0.0;
  StepReport lastReport_;
  std::uint64_t appliedAtStep_ = 0;  // the state the commands applied last took effect in
  double appliedAtTime_ = 0.0;
  std::uint64_t failedSteps_ = 0;
  int failedAttempts_ = 0;      // failed attempts in a row at the current step while running
  SelfPause selfPause_ = SelfPause::None;  // while paused by itself: for what
  std::string selfPauseWhy_;                // and why, in words (the core's refusal for a failing step)
  std::optional<ros::WallTime> frameWaitSince_;  // waiting for followed frames since
  std::vector<std::string> framesWaitedFor_;
  ros::WallTime lastClock_;  // wall time of the last /clock
  ros::Time clock_;          // and the time it gave
  // The step index and stamp of the state last published on ~state (none before the first).
  std::optional<std::pair<std::uint64_t, ros::Time>> publishedState_;
  std::array<std::uint64_t, kCommandTopics> inboxRefusalsTold_{};
  std::string lastProblem_;
  ros::WallTime lastDiagnostics_;
  bool diagnosticsSoon_ = false;

  std::vector<ros::Subscriber> commandSubs_;  // one per command topic (Command's order)
  std::vector<ros::Publisher> appliedPubs_;   // ~applied_<topic>, likewise
  ros::Publisher meshPub_, statePub_, energyPub_, statsPub_, pinForcesPub_,
      pinWrenchPub_, clockPub_, diagnosticsPub_, scenePub_,
      obstacleMarkerPub_;
  std::vector<ros::Publisher> obstacleWrenchPubs_;  // ~obstacles/<name>/wrench, scene order
  std::map<std::string, ros::Publisher> graspWrenchPubs_;  // ~grasp/<frame>/wrench, by frame
  std::unique_ptr<LiveServices> live_;  // ~set, the obstacle services, ~grasp_nearest
  std::string sceneText_;
  ros::ServiceServer resetSrv_, pauseSrv_, resumeSrv_, stepSrv_, advanceSrv_;
};

}  // namespace fem_cloth
