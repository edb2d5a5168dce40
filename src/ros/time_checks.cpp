#include "fem_cloth/ros/time_checks.h"

#include <cmath>
#include <cstdint>
#include <limits>

#include "fem_cloth/ros/time_text.h"

namespace fem_cloth {

namespace {

// "<what> = <value> s" for the messages.
std::string named(const std::string& what, double seconds) {
  return what + " = " + secondsText(seconds) + " s";
}

}  // namespace

Expected<ros::Duration> checkedDuration(double seconds, const std::string& what) {
  if (!std::isfinite(seconds)) return Error{named(what, seconds) + " is not a finite duration"};
  if (!(std::fabs(seconds) < kMaxRosDuration)) {
    return Error{named(what, seconds) + " is longer than a ROS duration can be (" +
                 secondsText(kMaxRosDuration) + " s, 68 years)"};
  }
  return ros::Duration(seconds);
}

Expected<ros::Time> checkedTime(double seconds, const std::string& what) {
  if (!std::isfinite(seconds) || seconds < 0.0) {
    return Error{named(what, seconds) + " is not a ROS time (a finite number of seconds >= 0)"};
  }
  if (seconds > kMaxRosDuration) {
    return Error{named(what, seconds) + " is later than " + secondsText(kMaxRosDuration) +
                 " s (19 January 2038): the difference to ROS time now would not fit a ROS "
                 "duration (32-bit seconds)"};
  }
  return ros::Time(seconds);
}

double secondsBetween(const ros::Time& t, const ros::Time& origin) {
  // Both are below 2^32 s, so their nanoseconds differ by less than 2^63.
  const std::int64_t nsec = static_cast<std::int64_t>(t.toNSec()) - static_cast<std::int64_t>(origin.toNSec());
  const std::int64_t whole = nsec / 1000000000LL;
  return static_cast<double>(whole) + 1e-9 * static_cast<double>(nsec - whole * 1000000000LL);
}

Expected<double> checkedSecondsSince(const ros::Time& t, const ros::Time& origin,
                                     const std::string& what) {
  const double d = secondsBetween(t, origin);
  if (!(std::fabs(d) < kMaxRosDuration)) {
    return Error{what + " = " + rosTimeText(t) + " s is " + secondsText(d) +
                 " s from the simulation's time origin (ROS time " + rosTimeText(origin) +
                 " s): more than a ROS duration can be (" + secondsText(kMaxRosDuration) + " s)"};
  }
  return d;
}

Expected<ros::Time> checkedTimeAfter(const ros::Time& origin, double seconds,
                                     const std::string& what) {
  constexpr double kTimeSpan = 4294967296.0;  // 2^32 s: every ROS time is below it
  constexpr std::int64_t kNsec = 1000000000LL;
  if (std::isfinite(seconds) && std::fabs(seconds) < kTimeSpan) {
    // Split as ros::Duration(seconds) does (whole seconds, then rounded nanoseconds), so that the
    // result is bit for bit origin + ros::Duration(seconds) wherever that does not throw.
    const double whole = std::floor(seconds);
    const std::int64_t nsec = static_cast<std::int64_t>(origin.toNSec()) +
                              static_cast<std::int64_t>(whole) * kNsec +
                              static_cast<std::int64_t>(std::llround((seconds - whole) * 1e9));
    if (nsec >= 0 && nsec < static_cast<std::int64_t>(kTimeSpan) * kNsec) {
      ros::Time t;
      t.fromNSec(static_cast<std::uint64_t>(nsec));
      return t;
    }
  }
  return Error{named(what, seconds) + " after ROS time " + rosTimeText(origin) +
               " s is not a ROS time (0 to 2^32 s)"};
}

}  // namespace fem_cloth
