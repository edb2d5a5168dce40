// fem_cloth_grasp_demo: a scripted grasp-and-lift for fem_cloth_node, as a robot would drive it.
//
// It waits for the cloth, broadcasts a "gripper" tf frame at the midpoint of two cloth vertices
// (by default the two corners of the far edge), pins them to that frame (PIN_IN_PLACE in the
// gripper frame, so they follow it), lifts and moves the frame along a smooth ramp, releases the
// scene's own pins so the cloth hangs from the gripper, holds, and exits.
//
// The default motion takes the far corners of the hanging-cloth scene while the cloth is still
// nearly flat, lifts them 0.5 m while bringing them half way towards the pinned edge (the cloth
// stays slack and folds over), then releases the pinned edge so the cloth hangs from the
// gripper. Times are simulation times (step x dt), so the script does the same thing however
// fast the node runs. If the node was started paused, the script resumes it once it listens.
//
// Private parameters: cloth_node (/fem_cloth_node), frame (gripper), parent_frame (world),
// grasp_vertices (two indices; default: the far edge's corners), start (s of simulation time,
// 0.05), lift (m, 0.5), approach (fraction of the horizontal way to the pinned vertices, 0.5),
// duration (s, 2.0), release_others (true), hold (s, 2.5).
//
// Exit status: 0 done, 2 bad parameters (the message names the parameter), 3 it could not drive
// the node (no node, no mesh, an unexpected error): one line on stderr in every case.
#include <ros/ros.h>
#include <shape_msgs/Mesh.h>
#include <tf2_ros/transform_broadcaster.h>

#include <cmath>
#include <iostream>

#include "fem_cloth/ClothState.h"
#include "fem_cloth/PinCommand.h"
#include "fem_cloth/PinForces.h"
#include <std_srvs/Trigger.h>

namespace {

struct Vec {
  double x = 0, y = 0, z = 0;
};

// Smooth 0 -> 1 ramp with zero velocity at both ends.
double ramp(double s) {
  if (s <= 0.0) return 0.0;
  if (s >= 1.0) return 1.0;
  return 0.5 - 0.5 * std::cos(M_PI * s);
}

// A vertex of the state's positions, or none (a grasp or pin vertex the state does not have).
bool hasVertex(const fem_cloth::ClothState& state, long v) {
  return v >= 0 && static_cast<std::size_t>(v) < state.positions.size();
}

int run(int argc, char** argv) {
  ros::init(argc, argv, "fem_cloth_grasp_demo");
  ros::NodeHandle nh, pnh("~");
  std::string cloth, frame, parent;
  std::vector<int> grasp;
  double start, lift, approach, duration, hold;
  bool releaseOthers;
  pnh.param<std::string>("cloth_node", cloth, "/fem_cloth_node");
  pnh.param<std::string>("frame", frame, "gripper");
  pnh.param<std::string>("parent_frame", parent, "world");
  pnh.param("grasp_vertices", grasp, std::vector<int>{});
  pnh.param("start", start, 0.05);
  pnh.param("lift", lift, 0.5);
  pnh.param("approach", approach, 0.5);
  pnh.param("duration", duration, 2.0);
  pnh.param("hold", hold, 2.5);
  pnh.param("release_others", releaseOthers, true);
  // Times are simulation times the script waits for: bounded, so that it ends.
  if (!(duration > 0 && duration <= 1e6) || !(start >= 0 && start <= 1e6) || !(hold >= 0 && hold <= 1e6)) {
    ROS_FATAL("fem_cloth_grasp_demo: ~duration must be in (0, 1e6] s, ~start and ~hold in [0, 1e6] s");
    return 2;
  }
  if (!(std::abs(lift) <= 1e3) || !(std::abs(approach) <= 1e3)) {
    ROS_FATAL("fem_cloth_grasp_demo: ~lift (m) and ~approach must be finite and at most 1e3 in size");
    return 2;
  }

  // The mesh tells which vertices to grasp: the two corners of the edge farthest along +y.
  auto mesh = ros::topic::waitForMessage<shape_msgs::Mesh>(cloth + "/mesh", nh, ros::Duration(30));
  if (!mesh || mesh->vertices.empty()) {
    ROS_FATAL_STREAM("fem_cloth_grasp_demo: no mesh on " << cloth << "/mesh");
    return 3;
  }
  if (grasp.empty()) {
    double maxY = -1e300;
    for (const auto& p : mesh->vertices) maxY = std::max(maxY, p.y);
    int lo = -1, hi = -1;
    for (std::size_t i = 0; i < mesh->vertices.size(); ++i) {
      const auto& p = mesh->vertices[i];
      if (std::abs(p.y - maxY) > 1e-9) continue;
      if (lo < 0 || p.x < mesh->vertices[lo].x) lo = static_cast<int>(i);
      if (hi < 0 || p.x > mesh->vertices[hi].x) hi = static_cast<int>(i);
    }
    grasp = {lo, hi};
  }
  if (grasp.size() != 2) {
    ROS_FATAL("fem_cloth_grasp_demo: ~grasp_vertices must list two vertices");
    return 2;
  }
  for (int v : grasp) {
    if (v < 0 || static_cast<std::size_t>(v) >= mesh->vertices.size()) {
      ROS_FATAL_STREAM("fem_cloth_grasp_demo: ~grasp_vertices: vertex " << v << " does not exist (the mesh has "
                       << mesh->vertices.size() << " vertices)");
      return 2;
    }
  }

  ros::Publisher pinPub = nh.advertise<fem_cloth::PinCommand>(cloth + "/pin", 10);
  fem_cloth::ClothState::ConstPtr latest;
  ros::Subscriber stateSub = nh.subscribe<fem_cloth::ClothState>(
      cloth + "/state", 5, [&latest](const fem_cloth::ClothState::ConstPtr& s) { latest = s; });
  fem_cloth::PinForces::ConstPtr pins;
  ros::Subscriber pinSub = nh.subscribe<fem_cloth::PinForces>(
      cloth + "/pin_forces", 5, [&pins](const fem_cloth::PinForces::ConstPtr& p) { pins = p; });
  tf2_ros::TransformBroadcaster broadcaster;

  // The node's step, from the scene it loaded.
  double dt = 0.0;
  if (!nh.getParam(cloth + "/integrator/dt", dt) || !(dt > 0.0)) {
    ROS_FATAL_STREAM("fem_cloth_grasp_demo: no positive " << cloth << "/integrator/dt parameter");
    return 3;
  }
  // Give the other listeners (a recorder) a moment, then resume a paused node.
  ros::WallDuration(1.0).sleep();
  ros::ServiceClient resume = nh.serviceClient<std_srvs::Trigger>(cloth + "/resume");
  std_srvs::Trigger trigger;
  if (resume.waitForExistence(ros::Duration(5.0))) resume.call(trigger);
  while (ros::ok() && !latest) {
    ros::spinOnce();
    ros::WallDuration(0.01).sleep();
  }
  if (!latest) return 0;  // shut down while waiting
  if (!hasVertex(*latest, grasp[0]) || !hasVertex(*latest, grasp[1])) {
    ROS_FATAL_STREAM("fem_cloth_grasp_demo: the state on " << cloth << "/state has "
                     << latest->positions.size() << " vertices, not the mesh's " << mesh->vertices.size());
    return 3;
  }
  // ROS time of simulation time 0, from a state's stamp and its step index.
  const ros::Time t0 = latest->header.stamp - ros::Duration(latest->step * dt);
  const double lead = 0.1;  // s: transforms are stamped ahead so the node can interpolate
  ROS_INFO_STREAM("fem_cloth_grasp_demo: grasping vertices " << grasp[0] << " and " << grasp[1]
                  << " at t = " << start << " s, lifting " << lift << " m over " << duration << " s");

  Vec origin, move;
  ros::Time lastBroadcast;
  bool grasped = false, released = false;
  ros::Rate rate(100.0);
  while (ros::ok()) {
    ros::spinOnce();
    const double t = (latest->header.stamp - t0).toSec();
    if (!grasped && t >= start - 0.2) {
      // Place the gripper at the corners' midpoint, broadcast, then grasp.
      if (!hasVertex(*latest, grasp[0]) || !hasVertex(*latest, grasp[1])) {
        ROS_FATAL("fem_cloth_grasp_demo: the cloth's state no longer has the grasp vertices");
        return 3;
      }
      const auto& a = latest->positions[grasp[0]];
      const auto& b = latest->positions[grasp[1]];
      origin = Vec{0.5 * (a.x + b.x), 0.5 * (a.y + b.y), 0.5 * (a.z + b.z)};
      // Towards the other pinned vertices (horizontally), a fraction `approach` of the way.
      if (pins) {
        Vec centre;
        int count = 0;
        for (std::uint32_t v : pins->vertices) {
          if (static_cast<int>(v) == grasp[0] || static_cast<int>(v) == grasp[1]) continue;
          if (!hasVertex(*latest, v)) continue;
          centre.x += latest->positions[v].x;
          centre.y += latest->positions[v].y;
          ++count;
        }
        if (count > 0) {
          move.x = approach * (centre.x / count - origin.x);
          move.y = approach * (centre.y / count - origin.y);
        }
      }
    }
    const double s = ramp((t - start) / duration);
    geometry_msgs::TransformStamped tf;
    tf.header.stamp = latest->header.stamp + ros::Duration(lead);
    tf.header.frame_id = parent;
    tf.child_frame_id = frame;
    const double sAhead = ramp((t + lead - start) / duration);
    tf.transform.translation.x = origin.x + sAhead * move.x;
    tf.transform.translation.y = origin.y + sAhead * move.y;
    tf.transform.translation.z = origin.z + sAhead * (move.z + lift);
    tf.transform.rotation.w = 1.0;
    // One transform per state (a repeated stamp would be dropped by tf listeners). The first
    // one is also sent for the current time, so the grasp instant is covered by tf.
    if (t >= start - 0.2 && tf.header.stamp != lastBroadcast) {
      if (lastBroadcast.isZero()) {
        geometry_msgs::TransformStamped now = tf;
        now.header.stamp = latest->header.stamp;
        broadcaster.sendTransform(now);
      }
      broadcaster.sendTransform(tf);
      lastBroadcast = tf.header.stamp;
    }
    if (!grasped && t >= start) {
      fem_cloth::PinCommand c;
      c.header.frame_id = frame;
      c.action = fem_cloth::PinCommand::PIN_IN_PLACE;
      c.vertices = {static_cast<std::uint32_t>(grasp[0]), static_cast<std::uint32_t>(grasp[1])};
      pinPub.publish(c);
      grasped = true;
      ROS_INFO("fem_cloth_grasp_demo: grasped");
    }
    if (grasped && !released && releaseOthers && s >= 1.0 && pins) {
      fem_cloth::PinCommand c;
      c.action = fem_cloth::PinCommand::RELEASE;
      for (std::uint32_t v : pins->vertices) {
        if (static_cast<int>(v) != grasp[0] && static_cast<int>(v) != grasp[1]) c.vertices.push_back(v);
      }
      if (!c.vertices.empty()) pinPub.publish(c);
      released = true;
      ROS_INFO("fem_cloth_grasp_demo: released the other pins; the cloth hangs from the gripper");
    }
    if (t >= start + duration + hold) break;
    rate.sleep();
  }
  ROS_INFO("fem_cloth_grasp_demo: done");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // Parameters and messages out of range (a stamp or step whose time ros::Duration cannot hold)
  // end the script with one line, not an abort.
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "fem_cloth_grasp_demo: " << e.what() << '\n';
    return 3;
  }
}
