#include "fem_cloth/ros/tf_intake.h"

#include <exception>

#include "fem_cloth/ros/time_checks.h"

namespace fem_cloth {

Status insertTransform(tf2::BufferCore& buffer, const geometry_msgs::TransformStamped& transform,
                       const std::string& authority, bool isStatic) {
  const std::string name =
      "transform '" + transform.header.frame_id + "' -> '" + transform.child_frame_id + "'";
  if (Expected<ros::Time> t = checkedTime(transform.header.stamp.toSec(), "the stamp of " + name); !t) {
    return Error{t.error()};
  }
  try {
    // tf2 says why itself (on the console) when it returns false.
    if (!buffer.setTransform(transform, authority, isStatic)) return Error{name + ": refused by tf2"};
  } catch (const std::exception& e) {
    return Error{name + ": " + e.what()};
  }
  return Status::success();
}

TfIntake::TfIntake(ros::NodeHandle node, tf2::BufferCore& buffer) : buffer_(buffer) {
  tf_ = node.subscribe<tf2_msgs::TFMessage>(
      "/tf", 100, [this](const ros::MessageEvent<tf2_msgs::TFMessage const>& e) { onMessage(e, false); });
  tfStatic_ = node.subscribe<tf2_msgs::TFMessage>(
      "/tf_static", 100, [this](const ros::MessageEvent<tf2_msgs::TFMessage const>& e) { onMessage(e, true); });
}

void TfIntake::onMessage(const ros::MessageEvent<tf2_msgs::TFMessage const>& event, bool isStatic) {
  const ros::Time now = ros::Time::now();
  {
    // On simulation time a bag played in a loop sends ROS time back: the transforms tf holds are
    // then from the future, and it starts over (as tf2_ros's listener does).
    std::lock_guard<std::mutex> lock(mutex_);
    if (now < lastMessage_) {
      ROS_WARN_STREAM("fem_cloth_node: ROS time jumped back " << secondsBetween(lastMessage_, now)
                                                              << " s: clearing tf");
      buffer_.clear();
    }
    lastMessage_ = now;
  }
  const std::string authority = event.getPublisherName();
  for (const geometry_msgs::TransformStamped& t : event.getConstMessage()->transforms) {
    const Status s = insertTransform(buffer_, t, authority, isStatic);
    if (s) continue;
    std::lock_guard<std::mutex> lock(mutex_);
    ++refusals_.count;
    refusals_.latest = (isStatic ? "/tf_static: " : "/tf: ") + s.error();
  }
}

TfIntake::Refusals TfIntake::takeRefusals() {
  std::lock_guard<std::mutex> lock(mutex_);
  Refusals r = refusals_;
  refusals_ = Refusals();
  return r;
}

}  // namespace fem_cloth
