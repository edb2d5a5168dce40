// fem_cloth_node: steps a cloth scene and serves it to ROS. A thin adapter over
// SimulationDriver: it reads parameters, wires topics and services, keeps time and publishes.
//
// Private parameters (beside the scene keys, see docs/scenes.md):
//   scene_file        string  a scene YAML (default: the package's config/hanging_cloth.yaml
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
//   replay_bag        string  a recorded run: its scene (unless one is given) and its time
//                             origin (start_time) are used, for replaying it live
// and the perception parameters (point cloud, camera, tf frames, marker look: perception.h).
#pragma once

#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>

#include "fem_cloth/Advance.h"
#include "fem_cloth/ros/perception.h"
#include "fem_cloth/ros/simulation_driver.h"

namespace fem_cloth {

class ClothNode {
 public:
  ClothNode(ros::NodeHandle node, ros::NodeHandle privateNode);
  ~ClothNode();

  /// Reads the parameters and builds the simulation. On a missing or invalid parameter returns
  /// false with one line naming it.
  bool start(std::string* error);
  /// Steps and publishes until ROS shuts down.
  void run();

  /// The names of the node's own private parameters (everything else under ~ is scene).
  static const std::vector<std::string>& parameterNames();

 private:
  enum class TimeMode { RealTime, Fast };

  bool readParameters(std::string* error);
  void onPin(const PinCommand::ConstPtr& msg);
  void onForce(const ForceCommand::ConstPtr& msg);
  void reject(const std::string& topic, const std::string& why);
  bool onReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  bool onPause(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  bool onResume(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  bool onStep(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  bool onAdvance(Advance::Request& req, Advance::Response& res);
  /// One step and its outputs (lock held by the caller).
  void stepOnce();
  /// /clock at the simulation time (fast mode only).
  void publishClock();
  void publishOutputs(const StepReport& report, double wallTime, bool force);
  void publishDiagnostics(bool force);
  bool wanted(const ros::Publisher& pub) const {
    return alwaysPublish_ || pub.getNumSubscribers() > 0;
  }

  ros::NodeHandle node_, private_;
  tf2_ros::Buffer tfBuffer_;
  std::unique_ptr<tf2_ros::TransformListener> tfListener_;
  std::unique_ptr<SimulationDriver> driver_;
  std::unique_ptr<PerceptionOutputs> perception_;  // ~points, ~camera/*, ~marker, tf frames
  std::mutex mutex_;
  std::condition_variable wake_;

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

  // Run state.
  bool paused_ = false;
  int stepRequests_ = 0;
  std::uint64_t publishEvery_ = 1, markerEvery_ = 1;
  ros::Time wallEpoch_;  // ROS time at which simulation time 0 is due (real_time mode)
  ros::WallTime rtfWindowStart_;
  double rtfWindowSimStart_ = 0.0, realTimeFactorMeasured_ = 0.0;
  double stepWallTime_ = 0.0;
  std::uint64_t rejected_ = 0, failedSteps_ = 0;
  std::string lastProblem_;
  ros::WallTime lastDiagnostics_;
  ros::WallTime tfWaitStart_;

  ros::Subscriber pinSub_, forceSub_;
  ros::Publisher meshPub_, statePub_, energyPub_, statsPub_, pinForcesPub_,
      pinWrenchPub_, clockPub_, diagnosticsPub_, scenePub_, appliedPinPub_, appliedForcePub_,
      obstacleMarkerPub_;
  std::vector<ros::Publisher> obstacleWrenchPubs_;  // ~obstacles/<name>/wrench, scene order
  std::string sceneText_;
  ros::ServiceServer resetSrv_, pauseSrv_, resumeSrv_, stepSrv_, advanceSrv_;
};

}  // namespace fem_cloth
