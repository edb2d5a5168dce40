#include "fem_cloth/core/contact/projection_contact.h"

#include <algorithm>
#include <cstdio>
#include <string>

#include "fem_cloth/core/contact/edge_distance.h"
#include "fem_cloth/core/contact/shapes.h"
#include "fem_cloth/core/contact/surface_check.h"
#include "fem_cloth/core/contact/surface_samples.h"

namespace fem_cloth {

namespace {
Eigen::Vector3d vertex(const VectorX& x, Index i) { return x.segment<3>(3 * i); }
}  // namespace

ProjectionContact::ProjectionContact(const Model& model, std::shared_ptr<ObstacleSet> obstacles,
                                     const ContactSettings& settings)
    : obstacles_(std::move(obstacles)),
      mass_(model.vertexMasses()),
      dHat_(settings.distance),
      tolerance_(surfaceTolerance(settings)),
      stretch_(settings.surfaceStretch) {
  projectedBy_.assign(static_cast<std::size_t>(mass_.size()), -1);
  for (std::size_t k = 0; k < obstacles_->size(); ++k) {
    if (obstacles_->hasEdgeDistance(k) || (*obstacles_)[k].shape.type == ShapeType::Box) {
      const Mesh& mesh = model.mesh();
      triangles_ = mesh.triangles;
      for (const Triangle& t : triangles_) restRadius_.push_back(restLatticeRadius(mesh, t));
      break;
    }
  }
}

void ProjectionContact::beginSubstep(double f0, double f1) {
  obstacles_->beginSubstep(f0, f1);
  std::fill(projectedBy_.begin(), projectedBy_.end(), -1);
  normalPush_.setZero(mass_.size());
  correction_.setZero(3 * mass_.size());
}

int ProjectionContact::project(VectorX& x, const VectorX& xStart, const std::vector<char>& pinned) {
  ObstacleSet& obstacles = *obstacles_;
  pinned_ = &pinned;
  int moved = 0;
  for (Index i = 0; i < mass_.size(); ++i) {
    if (pinned[static_cast<std::size_t>(3 * i)] != 0) continue;
    for (std::size_t k = 0; k < obstacles.size(); ++k) {
      const Eigen::Vector3d local = obstacles.inverseEnd(k) * vertex(x, i);
      SignedDistance sd = obstacles.shapeDistance(k, local);
      if (sd.distance >= dHat_) continue;
      if (sd.distance < 0.0) {
        // Inside: the nearest face may be the wrong one (a vertex that fell onto a table near
        // its edge is nearer the side). Use the surface where the vertex came in instead, found
        // by bisection on its path relative to the obstacle since the start of the substep; its
        // tangent plane supports the (convex) shape, so the vertex pushed out to dHat in front
        // of it is outside (Bridson et al. 2002 resolve such cases by continuous detection).
        Eigen::Vector3d outside = obstacles.inverseStart(k) * vertex(xStart, i), inside = local;
        if (obstacles.shapeDistance(k, outside).distance > 0.0) {
          for (int it = 0; it < 50; ++it) {
            const Eigen::Vector3d middle = 0.5 * (outside + inside);
            (obstacles.shapeDistance(k, middle).distance > 0.0 ? outside : inside) = middle;
          }
          sd = signedDistance(obstacles[k].shape, outside);
        }
      }
      const double push = dHat_ - sd.normal.dot(local - sd.closest);
      const Eigen::Vector3d move = obstacles.poseEnd(k).linear() * (push * sd.normal);
      x.segment<3>(3 * i) += move;
      correction_.segment<3>(3 * i) += move;
      normalPush_[i] += push;
      projectedBy_[static_cast<std::size_t>(i)] = static_cast<int>(k);
      ++moved;
    }
  }
  return moved;
}

// Coulomb friction on the vertices projected in this substep (finishSubstep).
void ProjectionContact::applyFriction(VectorX& x, const VectorX& xStart) {
  ObstacleSet& obstacles = *obstacles_;
  for (Index i = 0; i < mass_.size(); ++i) {
    const int projected = projectedBy_[static_cast<std::size_t>(i)];
    if (projected < 0) continue;
    const std::size_t k = static_cast<std::size_t>(projected);
    if (!(obstacles[k].friction > 0.0)) continue;
    const SignedDistance sd = obstacles.distance(k, vertex(x, i), true);
    // Displacement relative to the obstacle's surface point under the vertex.
    const Eigen::Vector3d surfaceMotion = sd.closest - obstacles.poseStart(k) * (obstacles.inverseEnd(k) * sd.closest);
    const Eigen::Vector3d relative = vertex(x, i) - vertex(xStart, i) - surfaceMotion;
    const Eigen::Vector3d tangential = relative - relative.dot(sd.normal) * sd.normal;
    const double slide = tangential.norm();
    if (slide == 0.0) continue;
    // Coulomb: the friction impulse is at most mu times the normal one (Bridson et al. 2002,
    // section 7.2): the tangential displacement shrinks by at most mu x normalPush, and stops.
    const double removed = std::min(slide, obstacles[k].friction * normalPush_[i]);
    const Eigen::Vector3d change = -removed / slide * tangential;
    x.segment<3>(3 * i) += change;
    correction_.segment<3>(3 * i) += change;
  }
}

void ProjectionContact::finishSubstep(VectorX& x, const VectorX& xStart, double h, double massScale,
                                      ContactStats& stats) {
  applyFriction(x, xStart);
  ObstacleSet& obstacles = *obstacles_;
  std::vector<ObstacleWrench> wrench(obstacles.size());
  int contacts = 0;
  double work = 0.0;
  for (Index i = 0; i < mass_.size(); ++i) {
    const int k = projectedBy_[static_cast<std::size_t>(i)];
    if (k < 0) continue;
    ++contacts;
    const Eigen::Vector3d force = massScale * mass_[i] * vertex(correction_, i) / (h * h);  // on the cloth
    const SignedDistance sd = obstacles.distance(static_cast<std::size_t>(k), vertex(x, i), true);
    // The obstacle's work: the force times the motion of its surface point under the vertex
    // (zero for a resting obstacle: what the projection does beyond it is the cloth's own
    // energy change, which acceptance (b) judges).
    const Eigen::Vector3d surfaceMotion =
        sd.closest - obstacles.poseStart(static_cast<std::size_t>(k)) *
                         (obstacles.inverseEnd(static_cast<std::size_t>(k)) * sd.closest);
    work += force.dot(surfaceMotion);
    wrench[static_cast<std::size_t>(k)].force -= force;
    wrench[static_cast<std::size_t>(k)].torque -= sd.closest.cross(force);
    stats.minDistance = std::min(stats.minDistance, sd.distance);
  }
  obstacles.setWrenches(wrench);
  stats.contacts = contacts;
  stats.work += work;
  checkSurface(x, h, stats);
}

bool ProjectionContact::freeTriangle(const Triangle& t) const {
  if (pinned_ == nullptr) return true;
  const std::vector<char>& pinned = *pinned_;
  return pinned[static_cast<std::size_t>(3 * t[0])] == 0 && pinned[static_cast<std::size_t>(3 * t[1])] == 0 &&
         pinned[static_cast<std::size_t>(3 * t[2])] == 0;
}

void ProjectionContact::checkSurface(const VectorX& x, double h, ContactStats& stats) {
  for (std::size_t k = 0; k < obstacles_->size(); ++k) {
    if ((*obstacles_)[k].shape.type == ShapeType::Box) measureBoxDepth(x, k, h, stats);
  }
  for (std::size_t k = 0; k < obstacles_->size() && stats.crossing.empty(); ++k) {
    if (obstacles_->hasEdgeDistance(k)) checkRound(x, k, h, stats);
  }
}

void ProjectionContact::measureBoxDepth(const VectorX& x, std::size_t k, double h, ContactStats& stats) {
  const Eigen::Vector3d& half = (*obstacles_)[k].shape.halfExtents;
  const Eigen::Isometry3d& inverse = obstacles_->inverseEnd(k);
  // Each vertex in the box's frame, and which face planes it is beyond (bit 2i: p_i > h_i, bit
  // 2i + 1: p_i < -h_i): a triangle whose three vertices share a bit has no point in the box (a
  // cloth on a table's top), at the cost of one AND.
  local_.resize(3, mass_.size());  // sized once: no allocation after the first substep
  beyond_.resize(static_cast<std::size_t>(mass_.size()));
  for (Index i = 0; i < mass_.size(); ++i) {
    const Eigen::Vector3d p = inverse * vertex(x, i);
    local_.col(i) = p;
    unsigned char bits = 0;
    for (int j = 0; j < 3; ++j) {
      bits |= static_cast<unsigned char>(((p[j] > half[j]) << (2 * j)) | ((p[j] < -half[j]) << (2 * j + 1)));
    }
    beyond_[static_cast<std::size_t>(i)] = bits;
  }
  for (std::size_t t = 0; t < triangles_.size(); ++t) {
    const Triangle& tri = triangles_[t];
    if ((beyond_[static_cast<std::size_t>(tri[0])] & beyond_[static_cast<std::size_t>(tri[1])] &
         beyond_[static_cast<std::size_t>(tri[2])]) != 0) {
      continue;
    }
    const Eigen::Vector3d a = local_.col(tri[0]), b = local_.col(tri[1]), c = local_.col(tri[2]);
    // Exact: a triangle separated from the box shrunk by the deepest so far cannot be deeper
    // (a cloth beside a table's edge).
    const Eigen::Vector3d shrunk = half.array() - stats.boxDepth;
    if (triangleSeparatedFromBox(shrunk, a, b, c) || !freeTriangle(tri)) continue;
    const double depth = triangleBoxDepth(half, a, b, c);
    if (depth <= stats.boxDepth) continue;
    stats.boxDepth = depth;
    stats.boxDepthWhere = "triangle " + std::to_string(t) + " in box '" + (*obstacles_)[k].name + "'";
    if (depth > tolerance_ && stats.crossing.empty()) setCrossing(x, t, k, depth, h, stats);
  }
}

void ProjectionContact::setCrossing(const VectorX& x, std::size_t t, std::size_t k, double d, double h,
                                    ContactStats& stats) const {
  const ObstacleSet& obstacles = *obstacles_;
  const Triangle& tri = triangles_[t];
  // Why the check before the run (surface_reach.h) did not keep it within the tolerance.
  const double stretch = latticeRadius(vertex(x, tri[0]), vertex(x, tri[1]), vertex(x, tri[2])) / restRadius_[t];
  char why[200];
  if (stretch > stretch_) {
    std::snprintf(why, sizeof why, "this one is stretched to %.6g times its rest size, beyond the %.4g of contact.surface_stretch",
                  stretch, stretch_);
  } else {
    std::snprintf(why, sizeof why, "this one, stretched %.6g times, is within it: a vertex was not kept contact.distance out, as when "
                  "another obstacle pushes it back in",
                  stretch);
  }
  const double speed = (obstacles.poseEnd(k).translation() - obstacles.poseStart(k).translation()).norm() / h;
  char text[240];
  std::snprintf(text, sizeof text, ") is %.3f mm inside %s '%s' (moving at %.3g m/s), more than contact.surface_tolerance (%.3f mm)",
                1e3 * d, shapeTypeName(obstacles[k].shape.type).c_str(), obstacles[k].name.c_str(), speed,
                1e3 * tolerance_);
  stats.crossing = "triangle " + std::to_string(t) + " (vertices " + std::to_string(tri[0]) + ", " +
                   std::to_string(tri[1]) + ", " + std::to_string(tri[2]) + text +
                   ": the projection of the explicit steppers keeps vertices out of obstacles, not the triangles "
                   "between them, and the scene was checked for triangles up to contact.surface_stretch (" +
                   std::string(why) + "); backward_euler and bdf2 keep triangles out (docs/contact.md)";
}

void ProjectionContact::checkRound(const VectorX& x, std::size_t k, double h, ContactStats& stats) const {
  // The deepest point of any free triangle in the obstacle, exact (triangleShapeDistance), goes
  // into stats.boxDepth and boxDepthWhere with the boxes' (the run's status becomes a warning); a
  // triangle deeper than the tolerance fails the substep: before the run the registry cleared the
  // scene's triangles up to contact.surface_stretch (surface_reach.h), so this is one stretched
  // more, or a ball passing between the vertices.
  const ObstacleSet& obstacles = *obstacles_;
  const Shape& shape = obstacles[k].shape;
  const Eigen::Vector3d centre = obstacles.poseEnd(k).translation();  // the shape frame's origin
  const double reach = shape.radius + shape.halfLength;
  const Eigen::Isometry3d& inverse = obstacles.inverseEnd(k);
  for (std::size_t t = 0; t < triangles_.size(); ++t) {
    const Triangle& tri = triangles_[t];
    const Eigen::Vector3d a = vertex(x, tri[0]), b = vertex(x, tri[1]), c = vertex(x, tri[2]);
    // Every point of the triangle is within its longest side of a: farther than that from the
    // obstacle's bounding sphere (less a depth), it cannot reach that depth: neither the deepest
    // so far nor the tolerance.
    const double side = std::sqrt(std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()}));
    if ((a - centre).norm() - reach - side >= -std::min(stats.boxDepth, tolerance_) || !freeTriangle(tri)) continue;
    const double d = *triangleShapeDistance(shape, inverse * a, inverse * b, inverse * c);
    if (-d > stats.boxDepth) {
      stats.boxDepth = -d;
      stats.boxDepthWhere = "triangle " + std::to_string(t) + " in " + shapeTypeName(shape.type) + " '" +
                            obstacles[k].name + "'";
    }
    if (d >= -tolerance_) continue;
    setCrossing(x, t, k, -d, h, stats);
    return;
  }
}

}  // namespace fem_cloth
