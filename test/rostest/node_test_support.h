// Helpers for the node's integration tests: wait for messages (never sleep for a fixed time),
// check that messages carry finite numbers.
#pragma once

#include <geometry_msgs/TransformStamped.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <tf2_msgs/TFMessage.h>

#include <atomic>
#include <cstdint>
#include <cmath>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "fem_cloth/ClothEnergy.h"
#include "fem_cloth/ClothState.h"
#include "fem_cloth/ForceCommand.h"
#include "fem_cloth/PinCommand.h"

namespace fem_cloth_test {

constexpr const char* kNode = "/fem_cloth_node";
inline std::string topic(const std::string& name) { return std::string(kNode) + "/" + name; }

/// Calls the node's std_srvs/Trigger service `name` (~pause, ~resume, ~step, ~reset): true when
/// it answered success.
inline bool trigger(const std::string& name) {
  std_srvs::Trigger t;
  return ros::service::call(topic(name), t) && t.response.success;
}

// --- Commands and frames as the tests send them -------------------------------------------------

inline geometry_msgs::Point point(double x, double y, double z) {
  geometry_msgs::Point p;
  p.x = x;
  p.y = y;
  p.z = z;
  return p;
}

/// PIN_AT_TARGETS in `frame` (zero stamp: before the next step unless `stamp` is given).
inline fem_cloth::PinCommand pinAt(const std::string& frame, const std::vector<std::uint32_t>& vertices,
                                   const std::vector<geometry_msgs::Point>& targets,
                                   const ros::Time& stamp = ros::Time()) {
  fem_cloth::PinCommand c;
  c.header.frame_id = frame;
  c.header.stamp = stamp;
  c.action = fem_cloth::PinCommand::PIN_AT_TARGETS;
  c.vertices = vertices;
  c.targets = targets;
  return c;
}

inline fem_cloth::PinCommand pinInPlace(const std::string& frame, const std::vector<std::uint32_t>& vertices) {
  fem_cloth::PinCommand c;
  c.header.frame_id = frame;
  c.action = fem_cloth::PinCommand::PIN_IN_PLACE;
  c.vertices = vertices;
  return c;
}

inline fem_cloth::PinCommand release(const std::vector<std::uint32_t>& vertices) {
  fem_cloth::PinCommand c;
  c.action = fem_cloth::PinCommand::RELEASE;
  c.vertices = vertices;
  return c;
}

/// APPLY one force on every vertex listed, for `duration` s.
inline fem_cloth::ForceCommand push(const std::string& frame, const std::vector<std::uint32_t>& vertices,
                                    double fx, double fy, double fz, double duration) {
  fem_cloth::ForceCommand c;
  c.header.frame_id = frame;
  c.action = fem_cloth::ForceCommand::APPLY;
  c.vertices = vertices;
  geometry_msgs::Vector3 f;
  f.x = fx;
  f.y = fy;
  f.z = fz;
  c.forces = {f};
  c.duration = duration;
  return c;
}

/// `child` at (x, y, z) in `parent`, unrotated, at `stamp`.
inline geometry_msgs::TransformStamped frameAt(const std::string& parent, const std::string& child,
                                               const ros::Time& stamp, double x, double y, double z) {
  geometry_msgs::TransformStamped tf;
  tf.header.stamp = stamp;
  tf.header.frame_id = parent;
  tf.child_frame_id = child;
  tf.transform.translation.x = x;
  tf.transform.translation.y = y;
  tf.transform.translation.z = z;
  tf.transform.rotation.w = 1.0;
  return tf;
}

/// Subscribes to a topic and keeps the latest message; waits until a predicate holds.
template <class M>
class Latest {
 public:
  explicit Latest(const std::string& name, std::function<void(const M&)> onEach = {})
      : onEach_(std::move(onEach)) {
    sub_ = nh_.subscribe<M>(name, 100, [this](const typename M::ConstPtr& msg) {
      std::lock_guard<std::mutex> lock(mutex_);
      latest_ = msg;
      ++count_;
      if (onEach_) onEach_(*msg);
    });
  }
  /// Spins until pred(latest) holds or the timeout (s) passes; returns the message or null.
  typename M::ConstPtr waitFor(std::function<bool(const M&)> pred, double timeout = 30.0) {
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
    while (ros::ok() && ros::WallTime::now() < end) {
      ros::spinOnce();
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (latest_ && pred(*latest_)) return latest_;
      }
      ros::WallDuration(0.002).sleep();
    }
    return nullptr;
  }
  typename M::ConstPtr waitForAny(double timeout = 30.0) {
    return waitFor([](const M&) { return true; }, timeout);
  }
  /// Waits for the next message after the ones seen so far.
  typename M::ConstPtr waitForNext(double timeout = 30.0) {
    std::size_t seen;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      seen = count_;
    }
    return waitFor([this, seen](const M&) { return count_ > seen; }, timeout);
  }
  std::size_t count() const { return count_; }
  /// Waits until the subscription is connected to a publisher (messages sent before are lost).
  bool waitConnected(double timeout = 10.0) {
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
    while (ros::ok() && sub_.getNumPublishers() == 0 && ros::WallTime::now() < end) {
      ros::WallDuration(0.01).sleep();
    }
    return sub_.getNumPublishers() > 0;
  }

 private:
  ros::NodeHandle nh_;
  ros::Subscriber sub_;
  std::function<void(const M&)> onEach_;
  std::mutex mutex_;
  typename M::ConstPtr latest_;
  std::size_t count_ = 0;
};

inline bool finite(const fem_cloth::ClothState& s) {
  for (const auto& p : s.positions) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return false;
  }
  for (const auto& v : s.velocities) {
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) return false;
  }
  return !s.positions.empty();
}

inline bool finite(const fem_cloth::ClothEnergy& e) {
  for (double v : {e.kinetic, e.strain, e.bending, e.gravity, e.external_work, e.pin_work,
                   e.dissipated, e.total, e.balance_error}) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

/// Waits until a publisher has `subscribers` subscribers connected (so a first message is not
/// lost; 2 when a recorder must hear it as well as the node).
inline bool waitForConnection(const ros::Publisher& pub, double timeout = 10.0, std::uint32_t subscribers = 1) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
  while (ros::ok() && pub.getNumSubscribers() < subscribers && ros::WallTime::now() < end) {
    ros::WallDuration(0.01).sleep();
  }
  return pub.getNumSubscribers() >= subscribers;
}

/// Publishes the transform make() returns on a /tf publisher every 10 ms, on a thread of its own,
/// until stop() or destruction (so however a test ends, an ASSERT returning early included).
class TfBroadcaster {
 public:
  TfBroadcaster(ros::Publisher& pub, std::function<geometry_msgs::TransformStamped()> make)
      : thread_([this, &pub, make = std::move(make)] {
          while (!stop_ && ros::ok()) {
            tf2_msgs::TFMessage message;
            message.transforms.push_back(make());
            pub.publish(message);
            ros::WallDuration(0.01).sleep();
          }
        }) {}
  ~TfBroadcaster() { stop(); }
  void stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace fem_cloth_test
