#include "fem_cloth/core/contact/obstacle_set.h"

#include <algorithm>

namespace fem_cloth {

ObstacleSet::ObstacleSet(std::vector<Obstacle> obstacles) : obstacles_(std::move(obstacles)) {
  frameStart_.assign(obstacles_.size(), Eigen::Isometry3d::Identity());
  frameEnd_ = frameStart_;
  poseStart_ = poseEnd_ = inverseStart_ = inverseEnd_ = frameStart_;
  wrenches_.assign(obstacles_.size(), ObstacleWrench());
  margin_.assign(obstacles_.size(), 0.0);
  beginSubstep(0.0, 0.0);
}

void ObstacleSet::setFramePose(std::size_t k, const Eigen::Isometry3d& start, const Eigen::Isometry3d& end) {
  frameStart_[k] = start;
  frameEnd_[k] = end;
}

void ObstacleSet::beginStep(double time, double dt) {
  time_ = time;
  dt_ = dt;
}

void ObstacleSet::commitStep() {
  time_ += dt_;
  dt_ = 0.0;
  frameStart_ = frameEnd_;
}

void ObstacleSet::reset() {
  time_ = dt_ = 0.0;
  std::fill(frameStart_.begin(), frameStart_.end(), Eigen::Isometry3d::Identity());
  frameEnd_ = frameStart_;
  std::fill(wrenches_.begin(), wrenches_.end(), ObstacleWrench());
}

Eigen::Isometry3d ObstacleSet::shapePoseAt(std::size_t k, double fraction) const {
  const Obstacle& o = obstacles_[k];
  Eigen::Isometry3d pose = interpolatePose(frameStart_[k], frameEnd_[k], fraction);
  if (o.scripted()) pose.translate(o.offsetAt(time_ + fraction * dt_));
  return pose * o.geometry;
}

void ObstacleSet::beginSubstep(double f0, double f1) {
  for (std::size_t k = 0; k < obstacles_.size(); ++k) {
    poseStart_[k] = shapePoseAt(k, f0);
    poseEnd_[k] = shapePoseAt(k, f1);
    inverseStart_[k] = poseStart_[k].inverse();
    inverseEnd_[k] = poseEnd_[k].inverse();
  }
}

SignedDistance ObstacleSet::distanceAt(std::size_t k, const Eigen::Vector3d& p, bool atEnd) const {
  const Eigen::Isometry3d& pose = atEnd ? poseEnd_[k] : poseStart_[k];
  const Eigen::Isometry3d& inverse = atEnd ? inverseEnd_[k] : inverseStart_[k];
  SignedDistance sd = signedDistance(obstacles_[k].shape, inverse * p);
  grow(sd, margin_[k]);
  sd.normal = pose.linear() * sd.normal;
  sd.closest = pose * sd.closest;
  return sd;
}

std::optional<EdgeShapeDistance> ObstacleSet::edgeDistanceAt(std::size_t k, const Eigen::Vector3d& a,
                                                             const Eigen::Vector3d& b, bool atEnd) const {
  const Eigen::Isometry3d& pose = atEnd ? poseEnd_[k] : poseStart_[k];
  const Eigen::Isometry3d& inverse = atEnd ? inverseEnd_[k] : inverseStart_[k];
  std::optional<EdgeShapeDistance> ed = edgeShapeDistance(obstacles_[k].shape, inverse * a, inverse * b);
  if (ed) {
    ed->surface.normal = pose.linear() * ed->surface.normal;
    ed->surface.closest = pose * ed->surface.closest;
  }
  return ed;
}

}  // namespace fem_cloth
