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
  /// Reads settings.distance, dHat (m): the gap vertices keep from the obstacles;
  /// surfaceTolerance(settings) (m): how deep a point between them may be inside an obstacle
  /// before the substep fails; surfaceStretch, for the message when one is.
  ProjectionContact(const Model& model, std::shared_ptr<ObstacleSet> obstacles, const ContactSettings& settings);

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
  /// obstacles' wrenches and the contact count. Last, the surface check (surface_check.h), on
  /// every triangle whose three vertices are free (the pin wins): the deepest point of any such
  /// triangle inside an obstacle, exact (triangleBoxDepth, triangleShapeDistance), into
  /// stats.boxDepth and boxDepthWhere (the projection keeps vertices out, not the points between
  /// them: reported); deeper than the tolerance, it sets stats.crossing, naming the triangle, the
  /// obstacle and its speed (the step fails). The registry refuses a scene whose triangles could
  /// reach deeper at contact.surface_stretch (surface_reach.h), so this fails only a triangle
  /// stretched beyond it, or pushed in by another obstacle.
  void finishSubstep(VectorX& x, const VectorX& xStart, double h, double massScale, ContactStats& stats);
  /// The displacement (per DOF, m) projection and friction gave x in this substep.
  const VectorX& correction() const { return correction_; }

  /// Distance evaluations so far (never reset: callers take differences).
  std::uint64_t checks() const { return obstacles_->checks(); }

 private:
  void applyFriction(VectorX& x, const VectorX& xStart);
  /// The surface check of finishSubstep: boxes, then round obstacles.
  void checkSurface(const VectorX& x, double h, ContactStats& stats);
  /// The deepest point of a free triangle in box k, into stats.boxDepth and boxDepthWhere; the
  /// first deeper than the tolerance, as stats.crossing.
  void measureBoxDepth(const VectorX& x, std::size_t k, double h, ContactStats& stats);
  /// The deepest point of a free triangle in round obstacle k, into stats.boxDepth and
  /// boxDepthWhere; the first deeper than the tolerance, as stats.crossing.
  void checkRound(const VectorX& x, std::size_t k, double h, ContactStats& stats) const;
  /// stats.crossing for a free triangle deeper than the tolerance in obstacle k (m, deepest d).
  void setCrossing(const VectorX& x, std::size_t t, std::size_t k, double d, double h, ContactStats& stats) const;
  bool freeTriangle(const Triangle& t) const;

  std::shared_ptr<ObstacleSet> obstacles_;
  VectorX mass_;  // per vertex (kg)
  double dHat_ = 0.0;
  double tolerance_ = 0.0;  // m, contact.surface_tolerance
  double stretch_ = 1.0;    // contact.surface_stretch
  std::vector<int> projectedBy_;  // per vertex: obstacle of the last projection, -1 none
  VectorX normalPush_;            // per vertex: distance projected along normals this substep (m)
  VectorX correction_;            // per DOF: displacement by projection and friction (m)
  std::vector<Triangle> triangles_;  // the mesh's triangles, if a box or a round obstacle needs them
  std::vector<double> restRadius_;   // per triangle: its lattice radius at rest (m)
  const std::vector<char>* pinned_ = nullptr;  // per DOF, from the last project()
  Eigen::Matrix3Xd local_;                      // the vertices in a box's frame (measureBoxDepth)
  std::vector<unsigned char> beyond_;           // per vertex: the box's face planes it is beyond
};

}  // namespace fem_cloth
