// Range checks for ROS times built from input. ROS 1 keeps a time in unsigned 32-bit seconds and a
// duration in signed 32-bit seconds, and rostime throws std::runtime_error ("... is out of dual
// 32-bit range") when a conversion or an operation leaves them: a message stamped
// {secs: 4294967295} minus the simulation's time origin is such a duration. Every time or duration
// the node and its driver build from input (a message stamp, a parameter, a recording) goes through
// these first, so that bad input is an error naming its field, never an exception.
#pragma once

#include <ros/time.h>

#include <string>

#include "fem_cloth/core/expected.h"

namespace fem_cloth {

/// A ros::Duration holds less than this (s): 2^31 - 1, about 68 years.
constexpr double kMaxRosDuration = 2147483647.0;

/// `seconds` as a ros::Duration, or an error naming `what` when it is not finite or not
/// below kMaxRosDuration in magnitude.
Expected<ros::Duration> checkedDuration(double seconds, const std::string& what);

/// `seconds` (a ROS time) as a ros::Time, or an error naming `what` when it is not finite,
/// negative, or later than kMaxRosDuration (19 January 2038): any two such times differ by a
/// ros::Duration, so the node can compare them with ROS time now without overflowing.
Expected<ros::Time> checkedTime(double seconds, const std::string& what);

/// t - origin in seconds, exact to the nanosecond (64-bit arithmetic: rostime's operator- throws
/// when the difference is beyond ±2^31 s); never throws.
double secondsBetween(const ros::Time& t, const ros::Time& origin);

/// t - origin in seconds, or an error naming `what` when no ros::Duration holds it.
Expected<double> checkedSecondsSince(const ros::Time& t, const ros::Time& origin,
                                     const std::string& what);

/// origin + seconds, or an error naming `what` when that is not a ros::Time (before 0 or from
/// 2^32 s on) or `seconds` is not finite.
Expected<ros::Time> checkedTimeAfter(const ros::Time& origin, double seconds,
                                     const std::string& what);

}  // namespace fem_cloth
