// ROS times in messages, in full.
#pragma once

#include <ros/time.h>

#include <sstream>
#include <string>

namespace fem_cloth {

/// `t` as ros::Time prints itself, to the nanosecond ("1796460000.123000000"): numberText would
/// print a ROS time of today as 1.79646e+09, which names no time a user can use (a
/// `rosbag filter` expression built from it keeps nothing).
inline std::string rosTimeText(const ros::Time& t) {
  std::ostringstream s;
  s << t;
  return s.str();
}

}  // namespace fem_cloth
