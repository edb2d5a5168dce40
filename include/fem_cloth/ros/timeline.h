// Simulation time -> ROS time, piecewise (docs/node.md, Time).
//
// A run starts with one segment: simulation time t is ROS time origin + t. A pause breaks that:
// ROS time goes on while simulation time stands still, so ~resume (and a ~step taken while
// paused) starts a new segment at the state's simulation time and ROS time now. Within a segment
// (step k0, simulation time s0, ROS time r0) the state at simulation time t is stamped
// r0 + (t - s0); a stamp r stands for simulation time s0 + (r - r0) in the last segment started
// by r, and a stamp inside a pause (after one segment's last step, before the next began) for the
// start of the next one. With the first segment alone this is the single time origin the node
// always had, bit for bit.
//
// A recording replays with the same segments, rebuilt from the stamps of its states
// (runTimeline(), bag_io.h). Such a segment knows its step but not yet the simulation time that
// step has (the simulator accumulates its time step after step): reach() fills it in when the
// replay gets there; until then it is placed at step x dt.
#pragma once

#include <ros/time.h>

#include <cstdint>
#include <string>
#include <vector>

#include "fem_cloth/core/expected.h"

namespace fem_cloth {

struct TimelineSegment {
  std::uint64_t step = 0;  ///< the first step taken in the segment starts from this state
  double time = 0.0;       ///< its simulation time (s); NaN until reach() (rebuilt segments)
  ros::Time stamp;         ///< its ROS time
};

class Timeline {
 public:
  /// One segment: simulation time 0 at ROS time `origin`.
  explicit Timeline(const ros::Time& origin = ros::Time());

  const std::vector<TimelineSegment>& segments() const { return segments_; }
  /// ROS time of simulation time 0.
  const ros::Time& origin() const { return segments_.front().stamp; }
  /// The segment the steps from `step` on are taken in: the last one starting at or before it.
  const TimelineSegment& at(std::uint64_t step) const;

  /// Starts a segment at the state (step, time) at ROS time `stamp`, or no earlier than where the
  /// segment in effect has come by then (stamps never go back, also when simulation time ran
  /// ahead of ROS time, real_time_factor > 1). Replaces a segment starting at the same step (no
  /// step was taken in it) and drops any after it.
  void start(std::uint64_t step, double time, const ros::Time& stamp);
  /// Appends a segment rebuilt from a recording: its simulation time comes with reach(). Steps
  /// must increase; one at the last segment's step replaces it.
  Status add(std::uint64_t step, const ros::Time& stamp);
  /// The state (step, time) is reached: fills in the simulation time of a segment starting
  /// there. True when it did (the mapping of stamps to simulation times moved).
  bool reach(std::uint64_t step, double time);

  /// The ROS time of simulation time `time` in the segment of `step` (at(step)), or an error
  /// naming `what` when that is no ROS time.
  Expected<ros::Time> stampOf(std::uint64_t step, double time, const std::string& what) const;
  /// The simulation time a ROS time stands for (see above). `dt` places segments not reached
  /// yet. An error names `what` when no ROS duration relates the stamp to its segment.
  Expected<double> timeOf(const ros::Time& stamp, double dt, const std::string& what) const;

 private:
  std::vector<TimelineSegment> segments_;
};

}  // namespace fem_cloth
