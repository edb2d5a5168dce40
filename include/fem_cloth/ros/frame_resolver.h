// Where a frame is, as the node's tf policy has it (docs/node.md, Frames): the pose of a frame
// in the simulation frame at a given ROS time, from a tf2 buffer. Exactly at that time when tf
// can interpolate there; else the nearest transform within tf_timeout stands in, and the answer
// says so (a replay may differ); else an error that names why (unknown frame, not connected,
// stale, not known yet).
//
// One lookup per frame and time: the exact poses found are kept until forgetBefore() drops
// them, so the step's commands, its frame-following pins, its obstacles and its wrench messages
// share one tf query for each frame at each time. (A kept pose would go out of date only if tf
// received, later, a transform stamped between the two it interpolated: tf publishers stamp in
// order.) No master needed.
#pragma once

#include <ros/time.h>
#include <tf2/buffer_core.h>

#include <cstdint>
#include <map>
#include <string>
#include <utility>

#include "fem_cloth/core/pin_set.h"

namespace fem_cloth {

class FrameResolver {
 public:
  /// tf may be null: then only the simulation frame resolves.
  FrameResolver(const tf2::BufferCore* tf, std::string simulationFrame, double tfTimeout)
      : tf_(tf), frame_(std::move(simulationFrame)), tfTimeout_(tfTimeout) {}

  /// An empty name, or the simulation frame's (with or without a leading '/').
  bool isSimulationFrame(const std::string& frame) const;
  const std::string& simulationFrame() const { return frame_; }
  /// The pose of `frame` in the simulation frame at `at` (see above).
  FramePose pose(const std::string& frame, const ros::Time& at) const;
  /// True when tf can interpolate `frame` at `at`, or when waiting cannot help: `at` is not
  /// later than the newest transform received (it precedes the frame's first transform, or
  /// falls in a gap), so the transform for it will never arrive.
  bool knownOrNeverWillBe(const std::string& frame, const ros::Time& at) const;
  /// Drops the kept poses of times before `t`.
  void forgetBefore(const ros::Time& t);
  /// tf lookups made so far (lookupTransform calls): what the cache saves, for tests.
  std::uint64_t lookups() const { return lookups_; }

 private:
  /// The pose at `at` when tf has it exactly, or in time before the newest transform.
  FramePose lookup(const std::string& frame, const ros::Time& at) const;
  /// Before the frame's first transform: the oldest one, found by bisection on canTransform.
  FramePose firstTransform(const std::string& frame, const ros::Time& at, const ros::Time& newest) const;
  geometry_msgs::TransformStamped tfLookup(const std::string& source, const ros::Time& at) const;

  const tf2::BufferCore* tf_;
  std::string frame_;
  double tfTimeout_;
  mutable std::map<std::pair<std::string, ros::Time>, Eigen::Isometry3d> exact_;
  mutable std::uint64_t lookups_ = 0;
};

}  // namespace fem_cloth
