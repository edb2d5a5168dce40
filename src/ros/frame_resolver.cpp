#include "fem_cloth/ros/frame_resolver.h"

#include <tf2/exceptions.h>
#include <tf2_eigen/tf2_eigen.h>

#include <optional>

#include "fem_cloth/ros/time_checks.h"
#include "fem_cloth/ros/time_text.h"
#include "fem_cloth/ros/transform_wait.h"

namespace fem_cloth {

namespace {

// Why tf cannot give `frame` at `at` when `at` lies further before the frame's newest transform
// than tf's cache keeps; nullopt when it is within the cache. tf2 keeps, per frame, the transforms
// from its newest back to the cache length (TimeCache prunes older ones as new ones come): a time
// before that is one tf held and dropped (or never had), and the oldest transform it kept must not
// stand in for it (a finger that moved meanwhile would jump into the cloth).
std::optional<std::string> goneFromTf(const tf2::BufferCore& tf, const std::string& frame, const ros::Time& at,
                                      const ros::Time& newest) {
  // getCacheLength() only reads; tf2 does not declare it const.
  const double kept = const_cast<tf2::BufferCore&>(tf).getCacheLength().toSec();
  const double before = secondsBetween(newest, at);
  if (before <= kept) return std::nullopt;
  return "tf no longer holds frame '" + frame + "' at " + rosTimeText(at) + " s: that is " + numberText(before) +
         " s before its newest transform, and tf keeps " + numberText(kept) +
         " s (tf_cache_time): the node is too far behind ROS time";
}

}  // namespace

bool FrameResolver::isSimulationFrame(const std::string& frame) const {
  return frame.empty() || tfFrameName(frame) == tfFrameName(frame_);
}

geometry_msgs::TransformStamped FrameResolver::tfLookup(const std::string& source, const ros::Time& at) const {
  ++lookups_;
  return tf_->lookupTransform(tfFrameName(frame_), source, at);
}

FramePose FrameResolver::pose(const std::string& frame, const ros::Time& at) const {
  if (isSimulationFrame(frame)) return FramePose(Eigen::Isometry3d::Identity());
  if (tf_ == nullptr) return FramePose::unknown("frame '" + frame + "' needs tf, which is not available here");
  const auto kept = exact_.find({tfFrameName(frame), at});
  if (kept != exact_.end()) return FramePose(kept->second);
  try {
    return lookup(frame, at);
  } catch (const tf2::TransformException& e) {
    return FramePose::unknown("frame '" + frame + "' is not connected to '" + tfFrameName(frame_) + "': " + e.what());
  } catch (const std::exception& e) {  // rostime's range errors, for transforms stamped far apart
    return FramePose::unknown("frame '" + frame + "': tf failed at " + rosTimeText(at) + " s: " + e.what());
  }
}

FramePose FrameResolver::lookup(const std::string& frame, const ros::Time& at) const {
  const std::string source = tfFrameName(frame);
  geometry_msgs::TransformStamped newest;
  try {
    newest = tfLookup(source, ros::Time(0));
  } catch (const tf2::LookupException& e) {
    // tf2 names the argument that does not exist; the simulation frame (target) is checked first.
    if (std::string(e.what()).find("target_frame") != std::string::npos) {
      return FramePose::unknown("frame '" + frame + "' cannot be related to the simulation frame '" +
                                         tfFrameName(frame_) + "': tf has no transform to it");
    }
    return FramePose::unknown("unknown frame '" + frame + "': tf has no such frame");
  }
  const ros::Time& latest = newest.header.stamp;
  if (latest.isZero() || at <= latest) {
    std::optional<Eigen::Isometry3d> exact;
    if (latest.isZero()) {
      exact = tf2::transformToEigen(newest);  // a static transform
    } else if (tf_->canTransform(tfFrameName(frame_), source, at)) {
      exact = tf2::transformToEigen(tfLookup(source, at));
    }
    if (exact) {
      exact_.emplace(std::make_pair(source, at), *exact);
      return FramePose(*exact);
    }
    if (std::optional<std::string> gone = goneFromTf(*tf_, frame, at, latest)) return FramePose::unknown(*gone);
    return firstTransform(frame, at, latest);
  }
  // Later than the newest transform (not yet received, or the frame stopped): the newest serves
  // if it is recent enough.
  const double age = secondsBetween(at, latest);
  if (age <= tfTimeout_) {
    return FramePose(tf2::transformToEigen(newest), "frame '" + frame + "' is not known yet at " +
                                                        rosTimeText(at) + " s; its newest transform, " +
                                                        numberText(age) + " s older, stands in");
  }
  return FramePose::unknown("frame '" + frame + "' is stale: its newest transform is " + numberText(age) +
                                     " s older than the time it is needed at (tf_timeout = " +
                                     numberText(tfTimeout_) + " s)");
}

FramePose FrameResolver::firstTransform(const std::string& frame, const ros::Time& at, const ros::Time& newest) const {
  // Earlier than tf can interpolate (before the frame's first transform, e.g. a frame that has
  // just appeared): the oldest one, found by bisection on canTransform, which holds on the whole
  // span tf has kept.
  const std::string source = tfFrameName(frame), target = tfFrameName(frame_);
  ros::Time unavailable = at, available = newest;
  while (secondsBetween(available, unavailable) > 1e-6) {
    const ros::Time mid = unavailable + (available - unavailable) * 0.5;
    (tf_->canTransform(target, source, mid) ? available : unavailable) = mid;
  }
  const double gap = secondsBetween(available, at);
  if (gap <= tfTimeout_) {
    return FramePose(tf2::transformToEigen(tfLookup(source, available)),
                     "frame '" + frame + "' is not known yet at " + rosTimeText(at) +
                         " s; its first transform, " + numberText(gap) + " s later, stands in");
  }
  return FramePose::unknown("frame '" + frame + "' is unknown at the time it is needed: its first transform " +
                                     "is " + numberText(gap) + " s later (tf_timeout = " + numberText(tfTimeout_) + " s)");
}

bool FrameResolver::knownOrNeverWillBe(const std::string& frame, const ros::Time& at) const {
  if (isSimulationFrame(frame)) return true;
  if (tf_ == nullptr) return false;
  const std::string source = tfFrameName(frame);
  if (exact_.count({source, at})) return true;
  try {
    if (tf_->canTransform(tfFrameName(frame_), source, at)) return true;
  } catch (const std::exception&) {  // rostime's range errors: pose() says what
    return true;
  }
  const std::optional<ros::Time> newest = newestTransform(*tf_, frame_, source);
  return newest && at <= *newest;  // nullopt: unknown or not connected (yet)
}

void FrameResolver::forgetBefore(const ros::Time& t) {
  for (auto it = exact_.begin(); it != exact_.end();) {
    it = it->first.second < t ? exact_.erase(it) : std::next(it);
  }
}

}  // namespace fem_cloth
