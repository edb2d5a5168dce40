#include "fem_cloth/ros/timeline.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "fem_cloth/ros/time_checks.h"

namespace fem_cloth {

namespace {

// A segment's simulation time, or where it is placed before it is reached.
double placed(const TimelineSegment& s, double dt) {
  return std::isnan(s.time) ? static_cast<double>(s.step) * dt : s.time;
}

/// The first segment that starts after `step`.
std::vector<TimelineSegment>::const_iterator firstAfter(const std::vector<TimelineSegment>& segments,
                                                        std::uint64_t step) {
  return std::upper_bound(segments.begin(), segments.end(), step,
                          [](std::uint64_t k, const TimelineSegment& s) { return k < s.step; });
}

}  // namespace

Timeline::Timeline(const ros::Time& origin) { segments_.push_back({0, 0.0, origin}); }

const TimelineSegment& Timeline::at(std::uint64_t step) const {
  return *std::prev(firstAfter(segments_, step));  // the first segment starts at step 0
}

void Timeline::start(std::uint64_t step, double time, const ros::Time& stamp) {
  segments_.erase(firstAfter(segments_, step), segments_.end());
  if (segments_.back().step == step) {
    if (segments_.size() == 1) {  // before the first step: the origin moves
      segments_.back().stamp = stamp;
      return;
    }
    segments_.pop_back();
  }
  // No earlier than where the segment in effect has come by now.
  const TimelineSegment& current = segments_.back();
  ros::Time begin = stamp;
  if (Expected<ros::Time> reached = stampOf(current.step, time, "simulation time"); reached && *reached > begin) {
    begin = *reached;
  }
  segments_.push_back({step, time, begin});
}

Status Timeline::add(std::uint64_t step, const ros::Time& stamp) {
  if (step < segments_.back().step) {
    return Error{"a segment of simulation time at step " + std::to_string(step) +
                 " comes after one at step " + std::to_string(segments_.back().step)};
  }
  if (step == segments_.back().step) {
    segments_.back().stamp = stamp;
    return Status::success();
  }
  segments_.push_back({step, std::numeric_limits<double>::quiet_NaN(), stamp});
  return Status::success();
}

bool Timeline::reach(std::uint64_t step, double time) {
  for (TimelineSegment& s : segments_) {
    if (s.step == step && std::isnan(s.time)) {
      s.time = time;
      return true;
    }
  }
  return false;
}

Expected<ros::Time> Timeline::stampOf(std::uint64_t step, double time, const std::string& what) const {
  const TimelineSegment& s = at(step);
  // The first segment: origin + time, as the single time origin always was.
  return checkedTimeAfter(s.stamp, s.step == 0 ? time : time - s.time, what);
}

Expected<double> Timeline::timeOf(const ros::Time& stamp, double dt, const std::string& what) const {
  auto after = std::upper_bound(segments_.begin(), segments_.end(), stamp,
                                [](const ros::Time& r, const TimelineSegment& s) { return r < s.stamp; });
  if (after != segments_.begin()) --after;  // before the origin: the first segment, negative time
  const Expected<double> since = checkedSecondsSince(stamp, after->stamp, what);
  if (!since) return since;
  // The first segment: stamp - origin, as the single time origin always was.
  double time = after == segments_.begin() ? *since : placed(*after, dt) + *since;
  if (std::next(after) != segments_.end()) time = std::min(time, placed(*std::next(after), dt));
  return time;
}

}  // namespace fem_cloth
