// The node's tf listener: /tf and /tf_static into a tf2 buffer, as tf2_ros::TransformListener
// does, except that a transform no ROS time arithmetic can handle is refused and counted instead
// of aborting the node. tf2's cache adds its length (10 s) to the stamps it holds, so a transform
// stamped {secs: 4294967295} throws std::runtime_error inside tf2 ("Time is out of dual 32-bit
// range") on the listener's thread, where nothing can catch it.
#pragma once

#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>
#include <tf2/buffer_core.h>
#include <tf2_msgs/TFMessage.h>

#include <cstdint>
#include <mutex>
#include <string>

#include "fem_cloth/core/expected.h"

namespace fem_cloth {

/// Inserts one transform, after checking its stamp (time_checks.h: below 2^31 s, like every
/// time the node takes); tf2's own refusals (NaN, an empty frame name) come back as errors too.
Status insertTransform(tf2::BufferCore& buffer, const geometry_msgs::TransformStamped& transform,
                       const std::string& authority, bool isStatic);

class TfIntake {
 public:
  /// Subscribes to /tf and /tf_static on `node`'s callback queue (its callbacks only insert).
  TfIntake(ros::NodeHandle node, tf2::BufferCore& buffer);

  struct Refusals {
    std::uint64_t count = 0;  ///< transforms refused since the last call
    std::string latest;       ///< why the latest one was
  };
  /// Thread-safe: for the run loop, which logs them (throttled).
  Refusals takeRefusals();

 private:
  void onMessage(const ros::MessageEvent<tf2_msgs::TFMessage const>& event, bool isStatic);

  tf2::BufferCore& buffer_;
  ros::Subscriber tf_, tfStatic_;
  std::mutex mutex_;
  ros::Time lastMessage_;  // ROS time of the last message: a jump back (a bag looping) clears tf
  Refusals refusals_;
};

}  // namespace fem_cloth
