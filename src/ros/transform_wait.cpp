#include "fem_cloth/ros/transform_wait.h"

#include <exception>

namespace fem_cloth {

std::string tfFrameName(const std::string& frame) {
  return !frame.empty() && frame[0] == '/' ? frame.substr(1) : frame;
}

std::optional<ros::Time> newestTransform(const tf2::BufferCore& tf, const std::string& target,
                                         const std::string& frame) {
  try {
    return tf.lookupTransform(tfFrameName(target), tfFrameName(frame), ros::Time(0)).header.stamp;
  } catch (const std::exception&) {  // tf2's exceptions, and rostime's range errors
    return std::nullopt;
  }
}

TransformWait::Verdict TransformWait::check(const std::vector<std::string>& notReady, double now,
                                            std::vector<std::string>* gaveUp) {
  std::vector<std::string> worth;
  for (const std::string& frame : notReady) {
    auto it = waitedOut_.find(frame);
    if (it != waitedOut_.end()) {
      if (newest_(frame) == it->second) continue;  // nothing new since the node gave up on it
      waitedOut_.erase(it);                        // it is back: wait for it again
    }
    worth.push_back(frame);
  }
  if (worth.empty()) {
    waitingSince_.reset();
    return Verdict::Step;
  }
  if (!waitingSince_) waitingSince_ = now;
  if (now - *waitingSince_ < timeout_) return Verdict::Wait;
  for (const std::string& frame : worth) waitedOut_[frame] = newest_(frame);
  waitingSince_.reset();
  if (gaveUp != nullptr) *gaveUp = worth;
  return Verdict::TimedOut;
}

void TransformWait::clear() {
  waitingSince_.reset();
  waitedOut_.clear();
}

}  // namespace fem_cloth
