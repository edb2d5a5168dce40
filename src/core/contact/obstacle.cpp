#include "fem_cloth/core/contact/obstacle.h"

namespace fem_cloth {

Eigen::Vector3d Obstacle::offsetAt(double t) const {
  if (!trajectory.empty()) {
    if (t <= trajectory.front().time) return trajectory.front().offset;
    for (std::size_t k = 1; k < trajectory.size(); ++k) {
      const TrajectoryPoint& a = trajectory[k - 1];
      const TrajectoryPoint& b = trajectory[k];
      if (t <= b.time) {
        const double f = (t - a.time) / (b.time - a.time);
        return (1.0 - f) * a.offset + f * b.offset;
      }
    }
    return trajectory.back().offset;
  }
  return velocity * t;
}

Eigen::Isometry3d interpolatePose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double f) {
  if (f <= 0.0) return a;
  if (f >= 1.0) return b;
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  if (a.linear() == b.linear()) {
    out.linear() = a.linear();
  } else {
    const Eigen::Quaterniond qa(a.linear()), qb(b.linear());
    out.linear() = qa.slerp(f, qb).toRotationMatrix();
  }
  out.translation() = (1.0 - f) * a.translation() + f * b.translation();
  return out;
}

Eigen::Matrix3d rotationFromRpy(const Eigen::Vector3d& rpy) {
  return (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

}  // namespace fem_cloth
