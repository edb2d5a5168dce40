#include "fem_cloth/render/camera.h"

#include <cmath>

namespace fem_cloth {

CameraIntrinsics CameraIntrinsics::fromHorizontalFov(int width, int height, double fov) {
  CameraIntrinsics k;
  k.width = width;
  k.height = height;
  k.fx = k.fy = 0.5 * width / std::tan(0.5 * fov);
  k.cx = 0.5 * (width - 1);
  k.cy = 0.5 * (height - 1);
  return k;
}

Status CameraIntrinsics::validate() const {
  // An upper bound keeps a typo (a width of 64000) from allocating gigabytes per frame.
  constexpr int kMaxSide = 8192;
  if (width < 1 || height < 1 || width > kMaxSide || height > kMaxSide) {
    return Error{"width and height must be 1 to " + std::to_string(kMaxSide) + " pixels, got " +
                 std::to_string(width) + " x " + std::to_string(height)};
  }
  if (!(fx > 0.0) || !(fy > 0.0) || !std::isfinite(fx) || !std::isfinite(fy)) {
    return Error{"fx and fy must be positive (pixels), got " + numberText(fx) + " and " +
                 numberText(fy)};
  }
  if (!std::isfinite(cx) || !std::isfinite(cy)) return Error{"cx and cy must be finite (pixels)"};
  return Status::success();
}

Expected<Eigen::Isometry3d> lookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                                   const Eigen::Vector3d& up) {
  const Eigen::Vector3d forward = target - eye;
  if (!forward.allFinite() || !eye.allFinite() || forward.norm() < 1e-9) {
    return Error{"the camera's position and the point it looks at must be finite and distinct"};
  }
  const Eigen::Vector3d z = forward.normalized();
  const Eigen::Vector3d right = z.cross(up);
  if (right.norm() < 1e-6 * up.norm() || !(up.norm() > 0.0)) {
    return Error{"the camera looks along its up direction: the image's rotation is undefined"};
  }
  const Eigen::Vector3d x = right.normalized();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear().col(0) = x;
  pose.linear().col(1) = z.cross(x);
  pose.linear().col(2) = z;
  pose.translation() = eye;
  return pose;
}

}  // namespace fem_cloth
