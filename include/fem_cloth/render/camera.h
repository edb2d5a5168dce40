// A pinhole camera as ROS describes one (sensor_msgs/CameraInfo, REP-104), in its optical frame
// (REP-103): z forward along the optical axis, x right, y down in the image. ROS-free.
//
// A point p = (x, y, z) in the optical frame, z > 0, projects to the image coordinates
//     u = fx x / z + cx,    v = fy y / z + cy,
// and the centre of the pixel in column i, row j is at (u, v) = (i, j): the convention of
// image_geometry::PinholeCameraModel, so that a consumer rounding the projection finds the pixel
// the renderer sampled there. Depth images hold z (the distance along the optical axis, not along
// the ray), in metres (REP-118). Units: pixels and metres.
#pragma once

#include <Eigen/Geometry>

#include "fem_cloth/core/expected.h"

namespace fem_cloth {

struct CameraIntrinsics {
  int width = 640;   ///< pixels
  int height = 480;  ///< pixels
  double fx = 554.26, fy = 554.26;  ///< focal lengths (pixels); the defaults give a 60 deg view
  double cx = 319.5, cy = 239.5;    ///< principal point (pixels)

  /// Square pixels, the principal point at the centre of the image ((w - 1) / 2, (h - 1) / 2),
  /// and a horizontal field of view of `fov` rad: fx = fy = (w / 2) / tan(fov / 2).
  static CameraIntrinsics fromHorizontalFov(int width, int height, double fov);
  /// Sizes positive, focal lengths positive and finite, principal point finite.
  Status validate() const;
  /// The image coordinates (u, v) of a point in the optical frame (z > 0).
  Eigen::Vector2d project(const Eigen::Vector3d& p) const {
    return {fx * p.x() / p.z() + cx, fy * p.y() / p.z() + cy};
  }
};

/// The pose (world from optical frame) of a camera at `eye` looking at `target`, with `up` (the
/// world's up, default +z) pointing up in the image: optical z = target - eye, x = z x up (right),
/// y = z x x (down). Errors when eye and target coincide or the view is along `up`.
Expected<Eigen::Isometry3d> lookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                                   const Eigen::Vector3d& up = Eigen::Vector3d::UnitZ());

}  // namespace fem_cloth
