// Rigid obstacles the cloth collides with: a shape (shapes.h) placed by a pose, a Coulomb
// friction coefficient, and how it moves:
//   - static;
//   - scripted: a constant velocity, or a piecewise-linear trajectory of offsets (fem_cloth_sim
//     and the node alike);
//   - following a tf frame (the node, and re-simulations of its recordings): the geometry is then
//     given in that frame, whose pose the ROS layer supplies at the start and end of every step.
// The world pose of the shape at time t is  frame(t) * translation(offset(t)) * geometry.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "fem_cloth/core/contact/shapes.h"

namespace fem_cloth {

struct TrajectoryPoint {
  double time = 0.0;                                ///< s
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  ///< m
};

struct Obstacle {
  std::string name;
  Shape shape;
  /// Where the shape's own frame sits in the obstacle's frame (the simulation frame, or `frame`).
  Eigen::Isometry3d geometry = Eigen::Isometry3d::Identity();
  double friction = 0.0;  ///< Coulomb coefficient mu (dimensionless)
  std::string frame;      ///< tf frame it follows (ROS only); empty: the simulation frame
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< m/s, scripted motion
  std::vector<TrajectoryPoint> trajectory;  ///< scripted motion: offsets at times (s), increasing

  bool scripted() const { return !velocity.isZero() || !trajectory.empty(); }
  /// Translation of the scripted motion at time t (m): velocity t, or the trajectory's offset
  /// interpolated linearly (held before the first and after the last point).
  Eigen::Vector3d offsetAt(double t) const;
};

/// Interpolates rigid poses: translations linearly, rotations by slerp; exact at f = 0 and 1.
Eigen::Isometry3d interpolatePose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double f);

/// Rotation from roll, pitch, yaw (rad) about the fixed x, y, z axes (REP-103): Rz(yaw) Ry(pitch) Rx(roll).
Eigen::Matrix3d rotationFromRpy(const Eigen::Vector3d& rpy);

}  // namespace fem_cloth
