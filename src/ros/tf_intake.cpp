#include "fem_cloth/ros/tf_intake.h"

#include <cmath>
#include <exception>
#include <optional>

#include "fem_cloth/ros/time_checks.h"
#include "fem_cloth/ros/time_text.h"
#include "fem_cloth/ros/transform_wait.h"

namespace fem_cloth {

namespace {

// Why tf2 refused `t`, which it says only on its console: a value it does not take, a stamp
// further before the frame's newest transform than it keeps (TF_OLD_DATA), or else — the one
// refusal left for a valid transform within its cache — a stamp it holds for the frame already
// (TF_REPEATED_DATA: a publisher that sends the same stamp twice).
std::string whyTf2Refused(tf2::BufferCore& buffer, const geometry_msgs::TransformStamped& t) {
  const geometry_msgs::Vector3& p = t.transform.translation;
  const geometry_msgs::Quaternion& q = t.transform.rotation;
  for (double v : {p.x, p.y, p.z, q.x, q.y, q.z, q.w}) {
    if (!std::isfinite(v)) return "refused by tf2: a value is not finite";
  }
  const std::string parent = tfFrameName(t.header.frame_id), child = tfFrameName(t.child_frame_id);
  if (parent.empty() || child.empty() || parent == child) return "refused by tf2: it names no frame, or one frame twice";
  if (std::abs(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w - 1.0) > 1e-5) {
    return "refused by tf2: its rotation is not a unit quaternion";
  }
  const std::optional<ros::Time> newest = newestTransform(buffer, parent, child);
  if (!newest) return "refused by tf2";
  const double kept = buffer.getCacheLength().toSec();
  if (secondsBetween(*newest, t.header.stamp) > kept) {
    return "refused by tf2: its stamp " + rosTimeText(t.header.stamp) + " s is more than the " + numberText(kept) +
           " s tf keeps (tf_cache_time) before the frame's newest transform, " + rosTimeText(*newest) +
           " s (TF_OLD_DATA)";
  }
  return "refused by tf2: a repeated timestamp, " + rosTimeText(t.header.stamp) + " s: tf holds a transform of '" +
         child + "' at that time already (TF_REPEATED_DATA; its publisher sent the same stamp twice)";
}

}  // namespace

Status insertTransform(tf2::BufferCore& buffer, const geometry_msgs::TransformStamped& transform,
                       const std::string& authority, bool isStatic) {
  const std::string name =
      "transform '" + transform.header.frame_id + "' -> '" + transform.child_frame_id + "'";
  if (Expected<ros::Time> t = checkedTime(transform.header.stamp.toSec(), "the stamp of " + name); !t) {
    return Error{t.error()};
  }
  try {
    // tf2 says why only on its console when it returns false: the error says it too.
    if (!buffer.setTransform(transform, authority, isStatic)) return Error{name + ": " + whyTf2Refused(buffer, transform)};
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
