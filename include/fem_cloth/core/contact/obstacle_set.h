// The rigid obstacles of a scene and where they are: the one thing the two contact methods share.
//
// Both methods — the barriers of the implicit steppers (contact_model.h) and the projection of
// the explicit ones (projection_contact.h) — ask the same questions of the obstacles: where each
// shape is at a fraction of the step being taken (frame poses from tf, scripted motion), how far
// a point is from it (counted: StepReport::contactChecks), and what force the cloth puts on it
// (the wrenches, for ~obstacle_wrenches and the summary). The Simulator owns the set and moves it
// through time (beginStep, commitStep, reset); the ROS layer sets frame poses on it and reads its
// poses and wrenches; the contact method in use reads and writes the rest.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "fem_cloth/core/contact/edge_distance.h"
#include "fem_cloth/core/contact/obstacle.h"

namespace fem_cloth {

struct ContactSettings {
  double distance = 1e-3;  ///< dHat (m): barriers act below it; explicit steppers keep vertices at it
  /// Barrier stiffness, as the acceleration (m/s^2) the barrier exerts on a vertex at dHat/2
  /// (kappa = stiffness / (|b'(dHat^2/4)| dHat)). 0: automatic, the magnitude of gravity (at least
  /// 9.81), so that a cloth resting under its own weight settles at about dHat/2.
  double stiffness = 0.0;
  bool selfCollision = false;
  double selfFriction = 0.0;       ///< mu of cloth on cloth
  double frictionVelocity = 1e-3;  ///< eps_v (m/s): slower relative sliding counts as sticking
  /// How far (size / rest size) a triangle may be stretched with the barrier integrators while
  /// the surface samples still keep every point of it out of spheres and capsules
  /// (surface_samples.h): larger takes more samples per triangle, or grows the obstacles more.
  double surfaceStretch = 1.5;
  /// m: how deep the explicit steppers, which keep only vertices out of obstacles, may let the
  /// surface between them reach into one (contact/surface_reach.h): checked before the run
  /// against a bound, measured after every substep. Negative: auto, contact.distance.
  double surfaceTolerance = -1.0;
};

/// contact.surface_tolerance (m), auto resolved to contact.distance.
inline double surfaceTolerance(const ContactSettings& c) {
  return c.surfaceTolerance >= 0.0 ? c.surfaceTolerance : c.distance;
}

/// The force the cloth exerts on an obstacle (N) and its moment about the simulation frame's
/// origin (N m), both in the simulation frame.
struct ObstacleWrench {
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  Eigen::Vector3d torque = Eigen::Vector3d::Zero();
};

/// What contact handling did in a (sub)step.
struct ContactStats {
  int contacts = 0;           ///< pairs closer than dHat (implicit) or vertices projected (others)
  /// J, work the obstacles did on the cloth: each contact's force on the cloth (barrier or
  /// projection, and friction) times the displacement of the obstacle's surface point under it
  /// over the substep. Zero for resting obstacles and for self-contact (internal forces).
  double work = 0.0;
  /// J, energy friction removed: minus each friction force times the cloth's displacement
  /// relative to the other side (obstacle or cloth), >= 0 (implicit steppers; the projection's
  /// friction and inelastic loss are not measured apart, they show as numerical dissipation).
  double dissipated = 0.0;
  /// J, energy stored in the barriers at the end of the substep (implicit steppers; 0 otherwise).
  double stored = 0.0;
  double minDistance = std::numeric_limits<double>::infinity();  ///< m, over contacts considered
  /// Not empty: the substep left the cloth through an obstacle (the projection's edge check):
  /// the step fails with this message.
  std::string crossing;
  /// m: how deep the cloth's surface reaches into a box between its vertices at the end of the
  /// substep (the explicit steppers keep vertices out, not the points between them;
  /// docs/contact.md): the implicit steppers' contact model (whose barriers keep it 0 in an
  /// accepted substep) measures at least the deepest of a grid of points on each
  /// triangle, the explicit steppers' projection the exact depth (surface_check.h); 0 when none
  /// is inside. Where: "triangle 99 in box 'table'".
  double boxDepth = 0.0;
  std::string boxDepthWhere;
};

class ObstacleSet {
 public:
  explicit ObstacleSet(std::vector<Obstacle> obstacles);

  std::size_t size() const { return obstacles_.size(); }
  bool empty() const { return obstacles_.empty(); }
  const Obstacle& operator[](std::size_t k) const { return obstacles_[k]; }

  // --- Motion over the step ----------------------------------------------------------------------
  /// The world pose of obstacle k's shape now (after the last step).
  Eigen::Isometry3d shapePose(std::size_t k) const { return shapePoseAt(k, 0.0); }
  /// Pose of the frame obstacle k follows at the start and the end of the next step (the ROS
  /// layer sets it from tf before each step; it stays where it is otherwise).
  void setFramePose(std::size_t k, const Eigen::Isometry3d& start, const Eigen::Isometry3d& end);
  /// Before a step from `time` (s) over dt (s); scripted motion is evaluated from these.
  void beginStep(double time, double dt);
  /// After a successful step: the end of the step becomes now.
  void commitStep();
  /// Back to time 0; frames to the identity, no wrenches.
  void reset();
  /// Shape pose at fraction f in [0, 1] of the step being taken.
  Eigen::Isometry3d shapePoseAt(std::size_t k, double fraction) const;

  // --- The substep being taken -------------------------------------------------------------------
  /// The shapes' poses at the fractions f0 and f1 of the step: a substep's start and end.
  void beginSubstep(double f0, double f1);
  const Eigen::Isometry3d& poseStart(std::size_t k) const { return poseStart_[k]; }
  const Eigen::Isometry3d& poseEnd(std::size_t k) const { return poseEnd_[k]; }
  const Eigen::Isometry3d& inverseStart(std::size_t k) const { return inverseStart_[k]; }
  const Eigen::Isometry3d& inverseEnd(std::size_t k) const { return inverseEnd_[k]; }
  /// Grows obstacle k by `margin` (m) for distance() and shapeDistance(): the barrier contact
  /// model grows round obstacles so that its surface samples keep whole triangles out
  /// (surface_samples.h). 0 by default; edgeDistance() always measures to the shape itself.
  void setMargin(std::size_t k, double margin) { margin_[k] = margin; }
  double margin(std::size_t k) const { return margin_[k]; }
  /// Signed distance of world point p to obstacle k (grown by its margin) at the substep's start
  /// or end, with the normal and the closest point in the world; counted in checks().
  SignedDistance distance(std::size_t k, const Eigen::Vector3d& p, bool atEnd) {
    ++checks_;
    return distanceAt(k, p, atEnd);
  }
  /// The same, not counted (const callers: per-vertex access).
  SignedDistance distanceAt(std::size_t k, const Eigen::Vector3d& p, bool atEnd) const;
  /// Signed distance of the world segment (a, b) to obstacle k at the substep's start or end
  /// (edge_distance.h: nothing for shapes without one), normal and closest point in the world;
  /// counted in checks().
  std::optional<EdgeShapeDistance> edgeDistance(std::size_t k, const Eigen::Vector3d& a,
                                                const Eigen::Vector3d& b, bool atEnd) {
    ++checks_;
    return edgeDistanceAt(k, a, b, atEnd);
  }
  /// The same, not counted.
  std::optional<EdgeShapeDistance> edgeDistanceAt(std::size_t k, const Eigen::Vector3d& a,
                                                  const Eigen::Vector3d& b, bool atEnd) const;
  /// Obstacle k has an edge distance (edge_distance.h).
  bool hasEdgeDistance(std::size_t k) const { return fem_cloth::hasEdgeDistance(obstacles_[k].shape.type); }
  /// Signed distance of a point given in obstacle k's shape frame (normal and closest point in
  /// that frame too); counted.
  SignedDistance shapeDistance(std::size_t k, const Eigen::Vector3d& local) {
    ++checks_;
    SignedDistance sd = signedDistance(obstacles_[k].shape, local);
    grow(sd, margin_[k]);
    return sd;
  }

  // --- What the cloth does to them ---------------------------------------------------------------
  /// Wrench on each obstacle at the end of the last step.
  const std::vector<ObstacleWrench>& wrenches() const { return wrenches_; }
  /// Copied into storage kept from call to call (no allocation once sized).
  void setWrenches(const std::vector<ObstacleWrench>& wrenches) { wrenches_ = wrenches; }

  /// Distance evaluations so far (never reset: callers take differences).
  std::uint64_t checks() const { return checks_; }

 private:
  std::vector<Obstacle> obstacles_;
  double time_ = 0.0, dt_ = 0.0;
  std::vector<Eigen::Isometry3d> frameStart_, frameEnd_;
  std::vector<Eigen::Isometry3d> poseStart_, poseEnd_, inverseStart_, inverseEnd_;
  std::vector<ObstacleWrench> wrenches_;
  std::vector<double> margin_;
  std::uint64_t checks_ = 0;
  static void grow(SignedDistance& sd, double margin) {
    sd.distance -= margin;
    sd.closest += margin * sd.normal;
  }
};

}  // namespace fem_cloth
