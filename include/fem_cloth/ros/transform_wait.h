// How long the node waits for transforms before a step (docs/node.md, Time). It waits, up to
// tf_timeout of wall time, until tf knows every frame the step needs at exactly its times, so that
// a replay sees the same frames. A frame whose publisher has stopped would make every later step
// wait tf_timeout again (one step per second); so a frame it has waited out once is not waited for
// again until tf receives a newer transform for it. (The driver drops the pins that follow such a
// frame once its newest transform is tf_timeout old in ROS time.)
#pragma once

#include <ros/time.h>
#include <tf2/buffer_core.h>

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace fem_cloth {

/// A frame name as tf2 keys it: without a leading '/'.
std::string tfFrameName(const std::string& frame);

/// The stamp of the newest transform tf has from `frame` to `target` (nullopt: none, or not
/// connected); a static transform has stamp 0. Either name may start with '/'.
std::optional<ros::Time> newestTransform(const tf2::BufferCore& tf, const std::string& target,
                                         const std::string& frame);

class TransformWait {
 public:
  /// newest(frame): the stamp of the newest transform tf has for the frame.
  using Newest = std::function<std::optional<ros::Time>(const std::string& frame)>;
  TransformWait(double timeout, Newest newest) : timeout_(timeout), newest_(std::move(newest)) {}

  enum class Verdict {
    Step,      ///< nothing worth waiting for: step now
    Wait,      ///< wait a little and ask again
    TimedOut,  ///< waited tf_timeout: step with what tf has (gaveUp names the frames)
  };
  /// `notReady`: the frames the next step needs that tf cannot give yet at exactly its times;
  /// `now`: wall time (s).
  Verdict check(const std::vector<std::string>& notReady, double now,
                std::vector<std::string>* gaveUp = nullptr);
  /// Forget every frame waited out (after ~reset).
  void clear();

 private:
  double timeout_;
  Newest newest_;
  std::optional<double> waitingSince_;
  std::map<std::string, std::optional<ros::Time>> waitedOut_;  // frame -> its newest stamp then
};

}  // namespace fem_cloth
