// Contact of the explicit steppers (symplectic Euler, XPBD) with rigid obstacles: vertices that
// come closer than dHat to an obstacle are projected out to dHat along its normal, and Coulomb
// friction removes tangential motion relative to the obstacle up to mu times that normal
// correction (Bridson, Fedkiw & Anderson, "Robust Treatment of Collisions, Contact and Friction
// for Cloth Animation", SIGGRAPH 2002, section 7). No self-collision here (the registry refuses
// it for these integrators).
//
// It is not a term of the incremental potential: it is a capability of the integrators that
// declare `IntegratorCapabilities::contact = ContactMethod::Projection`, and scene.cpp builds it,
// over the scene's ObstacleSet, only for them.
#pragma once

#include <array>
#include <memory>
#include <vector>

#include "fem_cloth/core/contact/obstacle_set.h"
#include "fem_cloth/core/model.h"

namespace fem_cloth {

class ProjectionContact {
 public:
  /// distance: dHat (m), the gap vertices keep from the obstacles.
  ProjectionContact(const Model& model, std::shared_ptr<ObstacleSet> obstacles, double distance);

  const ObstacleSet& obstacles() const { return *obstacles_; }
  double distance() const { return dHat_; }

  /// Starts a substep over the fraction [f0, f1] of the step: no vertex projected, no
  /// correction yet.
  void beginSubstep(double f0, double f1);
  /// Moves every free vertex closer than dHat to an obstacle (at the end of the substep) out to
  /// dHat along the obstacle's normal (a vertex inside: along the normal where its path from
  /// xStart entered); adds the distance moved to the vertex's normal push (m) and the
  /// displacement to the substep's correction (per DOF, m). Returns how many vertices it moved.
  int project(VectorX& x, const VectorX& xStart, const std::vector<char>& pinned);
  /// After a substep of length h: first Coulomb friction on the vertices projected in it (their
  /// displacement since xStart, relative to the obstacle's surface, loses its tangential part up
  /// to mu x normal push; x and the correction change accordingly), then the contact force
  /// massScale m correction / h^2 on each vertex (massScale = 1 + h alpha with implicit mass
  /// damping alpha, which scales the inertia of the update), the obstacles' work (that force
  /// times the motion of the obstacle's surface point under the vertex: ContactStats::work), the
  /// obstacles' wrenches and the contact count. Last, the edge check: an edge of the cloth more
  /// than dHat and half the radius inside a sphere or capsule (edge_distance.h; the projection
  /// keeps vertices out, not the edges between them) sets stats.crossing, naming the edge, the
  /// obstacle and its speed.
  void finishSubstep(VectorX& x, const VectorX& xStart, double h, double massScale, ContactStats& stats);
  /// The displacement (per DOF, m) projection and friction gave x in this substep.
  const VectorX& correction() const { return correction_; }

  /// Distance evaluations so far (never reset: callers take differences).
  std::uint64_t checks() const { return obstacles_->checks(); }

 private:
  void applyFriction(VectorX& x, const VectorX& xStart);
  void checkEdges(const VectorX& x, double h, ContactStats& stats);

  std::shared_ptr<ObstacleSet> obstacles_;
  VectorX mass_;  // per vertex (kg)
  double dHat_ = 0.0;
  std::vector<int> projectedBy_;  // per vertex: obstacle of the last projection, -1 none
  VectorX normalPush_;            // per vertex: distance projected along normals this substep (m)
  VectorX correction_;            // per DOF: displacement by projection and friction (m)
  std::vector<std::array<Index, 2>> edges_;  // the mesh's edges, if an obstacle has an edge distance
};

}  // namespace fem_cloth
