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

// The private parameters (see the top of the file).
struct Params {
  std::string cloth, frame, parent;
  std::vector<int> grasp;
  double start = 0.0, lift = 0.0, approach = 0.0, duration = 0.0, hold = 0.0;
  bool releaseOthers = true;
};

// The parameters, checked; false (after one line on stderr) when one is out of range.
bool readParams(const ros::NodeHandle& pnh, Params& p) {
  pnh.param<std::string>("cloth_node", p.cloth, "/fem_cloth_node");
  pnh.param<std::string>("frame", p.frame, "gripper");
  pnh.param<std::string>("parent_frame", p.parent, "world");
  pnh.param("grasp_vertices", p.grasp, std::vector<int>{});
  pnh.param("start", p.start, 0.05);
  pnh.param("lift", p.lift, 0.5);
  pnh.param("approach", p.approach, 0.5);
  pnh.param("duration", p.duration, 2.0);
  pnh.param("hold", p.hold, 2.5);
  pnh.param("release_others", p.releaseOthers, true);
  // Times are simulation times the script waits for: bounded, so that it ends.
  if (!(p.duration > 0 && p.duration <= 1e6) || !(p.start >= 0 && p.start <= 1e6) ||
      !(p.hold >= 0 && p.hold <= 1e6)) {
    ROS_FATAL("fem_cloth_grasp_demo: ~duration must be in (0, 1e6] s, ~start and ~hold in [0, 1e6] s");
    return false;
  }
  if (!(std::abs(p.lift) <= 1e3) || !(std::abs(p.approach) <= 1e3)) {
    ROS_FATAL("fem_cloth_grasp_demo: ~lift (m) and ~approach must be finite and at most 1e3 in size");
    return false;
  }
  return true;
}

// The two corners of the mesh's edge farthest along +y (the lowest and highest x on it).
std::vector<int> farEdgeCorners(const shape_msgs::Mesh& mesh) {
  double maxY = -1e300;
  for (const auto& p : mesh.vertices) maxY = std::max(maxY, p.y);
  int lo = -1, hi = -1;
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const auto& p = mesh.vertices[i];
    if (std::abs(p.y - maxY) > 1e-9) continue;
    if (lo < 0 || p.x < mesh.vertices[lo].x) lo = static_cast<int>(i);
    if (hi < 0 || p.x > mesh.vertices[hi].x) hi = static_cast<int>(i);
  }
  return {lo, hi};
}

// ~grasp_vertices (by default the far edge's corners): two vertices of the mesh, or false after
// one line on stderr.
bool chooseGrasp(const shape_msgs::Mesh& mesh, std::vector<int>& grasp) {
  if (grasp.empty()) grasp = farEdgeCorners(mesh);
  if (grasp.size() != 2) {
    ROS_FATAL("fem_cloth_grasp_demo: ~grasp_vertices must list two vertices");
    return false;
  }
  for (int v : grasp) {
    if (v < 0 || static_cast<std::size_t>(v) >= mesh.vertices.size()) {
      ROS_FATAL_STREAM("fem_cloth_grasp_demo: ~grasp_vertices: vertex " << v << " does not exist (the mesh has "
                       << mesh.vertices.size() << " vertices)");
      return false;
    }
  }
  return true;
}

// The grasp-and-lift, driven from the states the node publishes.
class GraspScript {
 public:
  GraspScript(ros::NodeHandle& nh, Params params)
      : p_(std::move(params)),
        pinPub_(nh.advertise<fem_cloth::PinCommand>(p_.cloth + "/pin", 10)),
        stateSub_(nh.subscribe<fem_cloth::ClothState>(
            p_.cloth + "/state", 5, [this](const fem_cloth::ClothState::ConstPtr& s) { latest_ = s; })),
        pinSub_(nh.subscribe<fem_cloth::PinForces>(
            p_.cloth + "/pin_forces", 5, [this](const fem_cloth::PinForces::ConstPtr& f) { pins_ = f; })) {}

  // Waits for the first state (0 when shut down while waiting, 3 when it lacks the grasp
  // vertices), then runs the motion to its end (dt: the node's step, s): the exit status.
  int run(ros::NodeHandle& nh, double dt, std::size_t meshVertices) {
    // Give the other listeners (a recorder) a moment, then resume a paused node.
    ros::WallDuration(1.0).sleep();
    ros::ServiceClient resume = nh.serviceClient<std_srvs::Trigger>(p_.cloth + "/resume");
    std_srvs::Trigger trigger;
    if (resume.waitForExistence(ros::Duration(5.0))) resume.call(trigger);
    while (ros::ok() && !latest_) {
      ros::spinOnce();
      ros::WallDuration(0.01).sleep();
    }
    if (!latest_) return 0;  // shut down while waiting
    if (!hasGraspVertices()) {
      ROS_FATAL_STREAM("fem_cloth_grasp_demo: the state on " << p_.cloth << "/state has "
                       << latest_->positions.size() << " vertices, not the mesh's " << meshVertices);
      return 3;
    }
    ROS_INFO_STREAM("fem_cloth_grasp_demo: grasping vertices " << p_.grasp[0] << " and " << p_.grasp[1]
                    << " at t = " << p_.start << " s, lifting " << p_.lift << " m over " << p_.duration << " s");
    ros::Rate rate(100.0);
    while (ros::ok()) {
      ros::spinOnce();
      // The state's simulation time: its step x dt, not its stamp less the first one's, which a
      // pause of the node moves on (a new segment of its timeline, docs/node.md, Time).
      const double t = static_cast<double>(latest_->step) * dt;
      if (!grasped_ && t >= p_.start - 0.2) {
        if (!hasGraspVertices()) {
          ROS_FATAL("fem_cloth_grasp_demo: the cloth's state no longer has the grasp vertices");
          return 3;
        }
        placeGripper();
      }
      if (t >= p_.start - 0.2) broadcast(t);
      if (!grasped_ && t >= p_.start) grasp();
      if (grasped_ && !released_ && p_.releaseOthers && ramp((t - p_.start) / p_.duration) >= 1.0 && pins_) {
        releaseOthers();
      }
      if (t >= p_.start + p_.duration + p_.hold) break;
      rate.sleep();
    }
    ROS_INFO("fem_cloth_grasp_demo: done");
    return 0;
  }

 private:
  static constexpr double kLead = 0.1;  // s: transforms are stamped ahead so the node can interpolate

  bool hasGraspVertices() const { return hasVertex(*latest_, p_.grasp[0]) && hasVertex(*latest_, p_.grasp[1]); }
  bool isGraspVertex(std::uint32_t v) const {
    return static_cast<int>(v) == p_.grasp[0] || static_cast<int>(v) == p_.grasp[1];
  }

  // The gripper at the grasp vertices' midpoint, moving towards the other pinned vertices
  // (horizontally), a fraction `approach` of the way.
  void placeGripper() {
    const auto& a = latest_->positions[p_.grasp[0]];
    const auto& b = latest_->positions[p_.grasp[1]];
    origin_ = Vec{0.5 * (a.x + b.x), 0.5 * (a.y + b.y), 0.5 * (a.z + b.z)};
    if (!pins_) return;
    Vec centre;
    int count = 0;
    for (std::uint32_t v : pins_->vertices) {
      if (isGraspVertex(v) || !hasVertex(*latest_, v)) continue;
      centre.x += latest_->positions[v].x;
      centre.y += latest_->positions[v].y;
      ++count;
    }
    if (count > 0) {
      move_.x = p_.approach * (centre.x / count - origin_.x);
      move_.y = p_.approach * (centre.y / count - origin_.y);
    }
  }

  // The gripper frame kLead ahead of the latest state (t: its simulation time). One transform per
  // state (a repeated stamp would be dropped by tf listeners); the first one is also sent for the
  // current time, so the grasp instant is covered by tf.
  void broadcast(double t) {
    geometry_msgs::TransformStamped tf;
    tf.header.stamp = latest_->header.stamp + ros::Duration(kLead);
    tf.header.frame_id = p_.parent;
    tf.child_frame_id = p_.frame;
    const double sAhead = ramp((t + kLead - p_.start) / p_.duration);
    tf.transform.translation.x = origin_.x + sAhead * move_.x;
    tf.transform.translation.y = origin_.y + sAhead * move_.y;
    tf.transform.translation.z = origin_.z + sAhead * (move_.z + p_.lift);
    tf.transform.rotation.w = 1.0;
    if (tf.header.stamp == lastBroadcast_) return;
    if (lastBroadcast_.isZero()) {
      geometry_msgs::TransformStamped now = tf;
      now.header.stamp = latest_->header.stamp;
      broadcaster_.sendTransform(now);
    }
    broadcaster_.sendTransform(tf);
    lastBroadcast_ = tf.header.stamp;
  }

  void grasp() {
    fem_cloth::PinCommand c;
    c.header.frame_id = p_.frame;
    c.action = fem_cloth::PinCommand::PIN_IN_PLACE;
    c.vertices = {static_cast<std::uint32_t>(p_.grasp[0]), static_cast<std::uint32_t>(p_.grasp[1])};
    pinPub_.publish(c);
    grasped_ = true;
    ROS_INFO("fem_cloth_grasp_demo: grasped");
  }

  // Releases the scene's own pins, so that the cloth hangs from the gripper.
  void releaseOthers() {
    fem_cloth::PinCommand c;
    c.action = fem_cloth::PinCommand::RELEASE;
    for (std::uint32_t v : pins_->vertices) {
      if (!isGraspVertex(v)) c.vertices.push_back(v);
    }
    if (!c.vertices.empty()) pinPub_.publish(c);
    released_ = true;
    ROS_INFO("fem_cloth_grasp_demo: released the other pins; the cloth hangs from the gripper");
  }

  const Params p_;
  ros::Publisher pinPub_;
  fem_cloth::ClothState::ConstPtr latest_;
  fem_cloth::PinForces::ConstPtr pins_;
  ros::Subscriber stateSub_, pinSub_;
  tf2_ros::TransformBroadcaster broadcaster_;
  ros::Time lastBroadcast_;
  Vec origin_, move_;
  bool grasped_ = false, released_ = false;
};

int run(int argc, char** argv) {
  ros::init(argc, argv, "fem_cloth_grasp_demo");
  ros::NodeHandle nh, pnh("~");
  Params params;
  if (!readParams(pnh, params)) return 2;
  // The mesh tells which vertices to grasp.
  auto mesh = ros::topic::waitForMessage<shape_msgs::Mesh>(params.cloth + "/mesh", nh, ros::Duration(30));
  if (!mesh || mesh->vertices.empty()) {
    ROS_FATAL_STREAM("fem_cloth_grasp_demo: no mesh on " << params.cloth << "/mesh");
    return 3;
  }
  if (!chooseGrasp(*mesh, params.grasp)) return 2;
  GraspScript script(nh, params);
  // The node's step, from the scene it loaded.
  double dt = 0.0;
  if (!nh.getParam(params.cloth + "/integrator/dt", dt) || !(dt > 0.0)) {
    ROS_FATAL_STREAM("fem_cloth_grasp_demo: no positive " << params.cloth << "/integrator/dt parameter");
    return 3;
  }
  return script.run(nh, dt, mesh->vertices.size());
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
