// ROS times in messages, in full.
#pragma once

#include <ros/time.h>

#include <cmath>
#include <iomanip>
#include <sstream>
#include <string>

#include "fem_cloth/core/expected.h"

namespace fem_cloth {

/// `t` as ros::Time prints itself, to the nanosecond ("1796460000.123000000"): numberText would
/// print a ROS time of today as 1.79646e+09, which names no time a user can use (a
/// `rosbag filter` expression built from it keeps nothing).
inline std::string rosTimeText(const ros::Time& t) {
  std::ostringstream s;
  s << t;
  return s.str();
}

/// A number of seconds that may be a ROS time (or a duration, a time out of range) in full: the
/// shortest decimal that reads back as the same double, never in exponent form below 1e12 s
/// ("1796460000.123", "2147483647", "-0.5"), where numberText would print 1.79646e+09; NaN,
/// infinities and 1e12 s on (no ROS time) as numberText prints them.
inline std::string secondsText(double seconds) {
  if (!std::isfinite(seconds) || std::fabs(seconds) >= 1e12) return numberText(seconds);
  // As many significant digits as the whole seconds have, at least: no exponent form.
  const int whole = std::fabs(seconds) >= 1.0 ? static_cast<int>(std::floor(std::log10(std::fabs(seconds)))) + 1 : 1;
  std::string text;
  for (int digits = whole; digits <= 17; ++digits) {
    std::ostringstream s;
    s << std::setprecision(digits) << seconds;
    text = s.str();
    if (std::stod(text) == seconds) break;
  }
  return text;
}

}  // namespace fem_cloth
