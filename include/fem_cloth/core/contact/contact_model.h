// Barrier contact of the cloth with rigid obstacles and, optionally, with itself.
//
// Implicit steppers (backward Euler, BDF2): Incremental Potential Contact (Li et al., "Incremental
// Potential Contact", SIGGRAPH 2020). The incremental potential gains
//     c^2 (kappa B(x) + D(x))
// with B a sum of log barriers (barrier.h) over every vertex-obstacle pair, every pair of a
// sphere or capsule and a lattice point of a triangle (surface_samples.h: so that no point of the
// surface enters a round obstacle between vertices) and, with self-collision, every
// point-triangle and edge-edge pair closer than the contact distance dHat, and D the lagged
// friction potential (section 5). Each barrier is weighted by the mass it pushes (the vertex's, or
// the mean of the pair's four vertices), so one stiffness kappa puts every vertex resting under
// the same acceleration at the same distance. The Newton line search never passes through
// anything: each step is bounded by continuous collision detection (ccd.h), and the barrier is
// +inf at zero distance. Pinned vertices are kinematic: they take no contact with obstacles (the
// pin wins), but do take part in self-contact.
//
// The explicit steppers project vertices out of obstacles instead (projection_contact.h); both
// methods work on the scene's ObstacleSet (obstacle_set.h), which says where the obstacles are.
//
// Only integrators with `IntegratorCapabilities::contact = ContactMethod::Barriers` get one, and
// a scene without obstacles and without self-collision builds none at all: no contact code runs
// (StepReport::contactChecks stays 0).
#pragma once

#include <Eigen/SparseCore>
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "fem_cloth/core/contact/obstacle_set.h"
#include "fem_cloth/core/contact/primitive_distance.h"
#include "fem_cloth/core/contact/surface_samples.h"
#include "fem_cloth/core/expected.h"
#include "fem_cloth/core/model.h"

namespace fem_cloth {

class ContactModel {
 public:
  /// gravity: its magnitude (m/s^2) sets the automatic stiffness.
  ContactModel(const Model& model, std::shared_ptr<ObstacleSet> obstacles, ContactSettings settings,
               double gravity);
  /// Over obstacles of its own (tests, code without a Simulator).
  ContactModel(const Model& model, std::vector<Obstacle> obstacles, ContactSettings settings,
               double gravity)
      : ContactModel(model, std::make_shared<ObstacleSet>(std::move(obstacles)), settings, gravity) {}

  const ContactSettings& settings() const { return settings_; }
  /// kappa (1/(s^2 m^2)): a barrier's energy is kappa m b(d^2) with m its mass weight (kg).
  double barrierStiffness() const { return kappa_; }
  const ObstacleSet& obstacles() const { return *obstacles_; }
  ObstacleSet& obstacles() { return *obstacles_; }

  /// The smallest distance between point-triangle and edge-edge pairs that share no vertex and
  /// are closer than dHat at x (m; inf if there are none).
  double minimumSelfDistance(const VectorX& x);

  /// Starts a substep of length h (s) over the fraction [f0, f1] of the step, from positions x0,
  /// with velocity gamma (x - xc): obstacle poses, and the lagged friction of Li et al. 2020
  /// (section 5.3): normal forces, tangent bases and contact points at x0, fixed for the substep.
  void beginSubstep(const VectorX& x0, const VectorX& xc, double gamma, double h,
                    const std::vector<char>& pinned, double f0, double f1);
  /// The first Newton iterate of a substep from positions x0: pinned vertices at their targets in
  /// `wanted`, free vertices as close to theirs as is safe. A free vertex that a moving obstacle
  /// comes to within dHat of moves with one of them (rigidly, which keeps its distance; once,
  /// however many come near: carryingObstacle()) instead of to `wanted`; then the others move to
  /// `wanted` if continuous collision detection finds the way free, else the pins first and the
  /// free vertices as far as they safely can. Fails, naming the vertex, when a vertex would still
  /// end inside an obstacle, or when the pins' motion alone would pass the cloth through itself
  /// (more substeps may help).
  Status startingPoint(const VectorX& x0, const VectorX& wanted, VectorX& x);
  /// Broad phase for the positions x + t dx, t in [0, 1] (dx may be zero), kept for the
  /// evaluations that follow, and the largest t that additive CCD finds collision-free
  /// (obstacles at the end of the substep; only self-contact if `withObstacles` is false).
  /// With perDof (3 per vertex), lowers each DOF's entry to the t at which its vertex would
  /// stop against an obstacle, or a self-contact pair it is in would stop.
  double prepareSegment(const VectorX& x, const VectorX& dx, bool withObstacles = true,
                        VectorX* perDof = nullptr);
  /// The parts of the contact's energy: the barriers kappa B, the lagged friction D, or both.
  enum class Part { Barriers, Friction, Both };
  /// kappa B(x) + D(x) (J), or one part of it, +inf if a distance is zero or negative. Adds
  /// scale x the gradient to `gradient`, and scale x the PSD-projected Hessian: into `hessian`
  /// where its pattern has the entries, else to `outside` as triplets. Uses the pairs of the last
  /// prepareSegment(). The energy is summed onto energyStart, element by element (so that the
  /// friction continued from the barriers' sum gives the bits of Part::Both).
  double evaluate(const VectorX& x, VectorX* gradient, SparseHessian* hessian,
                  std::vector<Eigen::Triplet<double>>* outside, double scale,
                  Part part = Part::Both, double energyStart = 0.0);
  /// Per-vertex access (local solvers; BarrierTerm's and FrictionTerm's vertexDerivatives, each
  /// its part): the force on `vertex`,
  /// -d(kappa B + D)/dx_v (N), and its 3 x 3 block of the Hessian evaluate() assembles (PSD:
  /// the barriers' Gauss-Newton part, the lagged friction's exact Hessian), from the vertex's
  /// obstacle barriers, the self-contact pairs of the last prepareSegment() and the substep's
  /// friction entries that hold it. False when one of those distances is zero or negative.
  /// Thread-safe; its distance evaluations are not counted in checks(). Needs
  /// prepareVertexAccess() after the last change of the pairs (prepareSegment, beginSubstep):
  /// until then false, `out` untouched.
  bool vertexDerivatives(const VectorX& x, Index vertex, VertexDerivatives& out,
                         Part part = Part::Both) const;
  /// Builds the per-vertex tables of the current pairs and friction entries (only when they
  /// changed since the last call): the Newton solver, which never asks, does not pay for them.
  void prepareVertexAccess();
  /// After a converged substep at x (from x0): contacts, the obstacles' wrenches, the work they
  /// did on the cloth (ContactStats::work: each contact's force times the motion of the
  /// obstacle's surface point under it), friction's loss, and the barriers' energy at x.
  void finishSubstep(const VectorX& x, const VectorX& x0, ContactStats& stats);
  /// The barriers' energy kappa B (J) at x with the obstacles where they are at the start of the
  /// step being taken (ObstacleSet::beginStep): what the energy balance holds in the contact at
  /// the start of a run. +inf if a distance is zero or negative.
  double storedEnergy(const VectorX& x, const std::vector<char>& pinned);

  /// At the start of a run (the obstacles at time 0, those following a tf frame left out, since
  /// only the node places them): every triangle with a free vertex (not in `pinned`) outside the
  /// spheres and capsules, and its lattice points outside them grown by their margins (so that
  /// the barrier is finite in the first step); else an error naming the obstacle and the triangle.
  Status checkSurfaceAtStart(const VectorX& x, const std::vector<Index>& pinned);

  /// The obstacles that move in the current substep, for a failed step's message: "obstacle
  /// 'ball' moves at 100 m/s (1000 mm in the substep, 500 contact.distance)", joined by "; ";
  /// empty if none moves.
  std::string movingObstaclesText() const;

  /// Distance evaluations so far, the obstacles' included (never reset: callers take differences).
  std::uint64_t checks() const { return checks_ + obstacles_->checks(); }

 private:
  struct Friction {
    std::array<Index, 4> vertices{};
    int count = 1;
    Eigen::Vector4d weights = Eigen::Vector4d::Zero();
    Eigen::Matrix<double, 3, 2> tangent;
    Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // obstacle motion over the substep / (h gamma)
    double muLambda = 0.0;                             // N
    int obstacle = -1;                                 // -1: self-contact
    Eigen::Vector3d point = Eigen::Vector3d::Zero();   // contact point (for the torque)
  };
  /// One barrier's share: its energy, gradient (over its 1 or 4 vertices) and PSD Hessian.
  struct VertexBarrier {
    double energy = 0.0;
    Eigen::Vector3d gradient = Eigen::Vector3d::Zero();  // dE/dx_i
    double weight = 0.0, along = 0.0;                    // Hessian: weight along n n^T
  };
  struct PairBarrier {
    bool active = false;  // closer than dHat
    double energy = 0.0;
    Eigen::Matrix<double, 12, 1> gradient;
    Eigen::Matrix<double, 12, 12> hessian;  // filled when asked
  };
  struct FrictionShare {
    double energy = 0.0;
    Eigen::Vector3d gradient = Eigen::Vector3d::Zero();  // per unit weight of a vertex
    Eigen::Matrix3d hessian = Eigen::Matrix3d::Zero();   // per unit weight product
  };
  VertexBarrier vertexBarrier(Index i, const SignedDistance& sd) const;
  /// Both: w b(d^2) for the weight w = kappa m (1/s^2).
  VertexBarrier massBarrier(double w, const SignedDistance& sd) const;
  /// False when the distance is zero or negative; `distance` gets it either way.
  bool pointTriangleBarrier(const VectorX& x, int p, int t, bool wantGradient, bool wantHessian,
                            PairBarrier& out, double& distance) const;
  bool edgeEdgeBarrier(const VectorX& x, int ia, int ib, bool wantGradient, bool wantHessian,
                       PairBarrier& out, double& distance) const;
  /// The barrier w b(s) of the point-triangle pair (X's columns p, t0, t1, t2) or, if edgeEdge,
  /// the edge-edge pair (a0, a1, b0, b1) mollified with threshold epsX, its gradient and PSD
  /// Hessian over the 12 coordinates; `pd` gets the distance's closest points.
  bool pairBarrier(const Eigen::Matrix<double, 3, 4>& X, bool edgeEdge, double w, double epsX,
                   bool wantGradient, bool wantHessian, PairBarrier& out, double& distance,
                   PrimitiveDistance& pd) const;
  /// The moving obstacle that carries a vertex at p (at the start of the substep) in the starting
  /// point: of those that come within dHat of it over the substep, the one whose motion leaves it
  /// farthest from every obstacle at the end; size() if none does, or if staying is farther.
  /// Only the obstacles marked in `reached` (size() entries: 1 the vertex, 2 a surface sample of
  /// one of its triangles comes within dHat of it over the substep) are candidates; staying is one
  /// only without a 2.
  std::size_t carryingObstacle(const Eigen::Vector3d& p, const char* reached);
  /// Whether moving obstacle k comes within dHat of the point p over the substep, the cloth held
  /// still (conservative advancement in its frame).
  bool obstacleReaches(std::size_t k, const Eigen::Vector3d& p);
  /// The obstacle's speed over the substep (m/s; its translation), for messages.
  double obstacleSpeed(std::size_t k) const;
  /// A surface sample takes obstacle contact when all its vertices are free: as a pinned vertex
  /// takes none (the pin wins, and may hold the cloth inside an obstacle), neither do the
  /// points of its triangles.
  bool sampleTakesContact(const SurfaceSample& s) const {
    for (int i = 0; i < s.count; ++i) {
      if (!isFree(s.vertices[static_cast<std::size_t>(i)])) return false;
    }
    return true;
  }
  static Eigen::Vector3d samplePoint(const VectorX& x, const SurfaceSample& s) {
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    for (int i = 0; i < s.count; ++i) p += s.weights[i] * x.segment<3>(3 * s.vertices[static_cast<std::size_t>(i)]);
    return p;
  }
  /// A cheap lower bound of the distance of p to round obstacle k (grown) where it ends the
  /// substep: from the sphere around it (its shape frame's origin is its centre), so that far
  /// surface samples cost no distance evaluation.
  double roundLowerBound(std::size_t k, const Eigen::Vector3d& p) const {
    const Shape& shape = (*obstacles_)[k].shape;
    return (p - obstacles_->poseEnd(k).translation()).norm() - (shape.radius + shape.halfLength + obstacles_->margin(k));
  }
  /// Samples the surface for the round obstacles and grows them (surface_samples.h).
  void sampleSurface(const Model& model);
  /// The first triangle that reaches into a round obstacle at x (the obstacles where they end
  /// the substep), as a message naming both; empty if none does.
  std::string surfaceCrossing(const VectorX& x) const;
  /// The deepest point of a grid on each triangle with a free vertex inside a box at x (a lower
  /// bound; 0 after an accepted substep, whose boxCrossing found no overlap), into
  /// stats.boxDepth and boxDepthWhere.
  void measureBoxDepth(const VectorX& x, ContactStats& stats) const;
  /// The same for obstacle k alone.
  std::string surfaceCrossing(const VectorX& x, std::size_t k) const;
  FrictionShare frictionShare(const Friction& f, const VectorX& x, bool wantHessian) const;
  /// The displacement over the substep of obstacle k's surface point that is at p at its end.
  Eigen::Vector3d surfaceMotion(std::size_t k, const Eigen::Vector3d& p) const;
  /// A friction entry's share of the obstacles' work and of friction's loss (finishSubstep), g
  /// its gradient at x.
  void addFrictionWork(const Friction& f, const VectorX& x, const Eigen::Vector3d& g,
                       ContactStats& stats) const;
  /// The parts of vertexDerivatives (added to out); false when a distance is not positive.
  bool addVertexBarriers(const VectorX& x, Index v, VertexDerivatives& out) const;
  void addVertexFriction(const VectorX& x, Index v, VertexDerivatives& out) const;
  bool isFree(Index vertex) const { return pinned_ == nullptr || (*pinned_)[3 * vertex] == 0; }
  /// A triangle takes obstacle contact beyond its vertices' only when all three are free.
  bool freeTriangle(const Triangle& t) const { return isFree(t[0]) && isFree(t[1]) && isFree(t[2]); }
  void addBlock(Index a, Index b, const Eigen::Matrix3d& block, SparseHessian* hessian,
                std::vector<Eigen::Triplet<double>>* outside) const;
  double evaluateAll(const VectorX& x, VectorX* gradient, SparseHessian* hessian,
                     std::vector<Eigen::Triplet<double>>* outside, double scale,
                     std::vector<ObstacleWrench>* wrench, ContactStats* stats,
                     Part part = Part::Both, double energyStart = 0.0);
  /// Where one evaluateAll() writes, and the energy it has summed so far.
  struct Assembly {
    VectorX* gradient = nullptr;
    SparseHessian* hessian = nullptr;
    std::vector<Eigen::Triplet<double>>* outside = nullptr;
    double scale = 1.0;
    std::vector<ObstacleWrench>* wrench = nullptr;
    ContactStats* stats = nullptr;
    double energy = 0.0;
    /// The wrench and the Hessian need the gradients of the distances too.
    bool wantsGradient() const { return gradient != nullptr || hessian != nullptr || wrench != nullptr; }
    void note(double distance, double dHat);
  };
  // The parts of evaluateAll, in its order; false when a distance is zero or negative.
  bool addObstacleBarriers(const VectorX& x, Assembly& a);
  bool addSampleBarriers(const VectorX& x, Assembly& a);
  bool addPointTriangleBarriers(const VectorX& x, Assembly& a);
  bool addEdgeEdgeBarriers(const VectorX& x, Assembly& a);
  bool addBoxPairBarriers(const VectorX& x, Assembly& a);
  void addFriction(const VectorX& x, Assembly& a) const;
  /// Adds a 4-vertex pair's gradient and (PSD) Hessian, times a.scale.
  void scatter(const std::array<Index, 4>& v, const Eigen::Matrix<double, 12, 1>& g,
               const Eigen::Matrix<double, 12, 12>* H, Assembly& a) const;
  void selfCandidates(const VectorX& x, const VectorX* dx);
  /// prepareSegment's self-contact part: the candidate pairs, and the largest t <= tMax that
  /// their CCD finds collision-free (per DOF as prepareSegment's).
  double selfSegment(const VectorX& x, const VectorX& dx, double tMax, VectorX* perDof);
  double edgeMollifierThreshold(Index ea, Index eb) const;

  // A stencil of vertices stored elsewhere (for VertexIncidence).
  struct Span {
    const Index* first;
    const Index* last;
    const Index* begin() const { return first; }
    const Index* end() const { return last; }
  };

  // Boxes (box_features.h): each corner against the cloth's triangles and each edge against the
  // cloth's edges, with IPC's point-triangle and edge-edge barriers, the box side where the box
  // ends the substep. Triangles and edges with a pinned vertex take none (the pin wins). The
  // pairs are those within reach of the last prepareSegment().
  struct BoxPair {
    int box;      // obstacle index
    int feature;  // corner (corner-triangle) or edge (edge-edge) of the box
    int cloth;    // triangle or edge of the cloth
    bool edgeEdge;
  };
  /// The pair's cloth vertices (3 or 2; the count returned).
  int boxPairVertices(const BoxPair& pair, std::array<Index, 3>& cloth) const;
  /// The pair's 4 points (the box's first, then its cloth vertices, which `cloth` gets).
  int boxPairPoints(const VectorX& x, const BoxPair& pair, Eigen::Matrix<double, 3, 4>& X,
                    std::array<Index, 3>& cloth, bool atEnd = true) const;
  /// The pair's barrier weight kappa m (m the mean mass of its cloth vertices: constant, so the
  /// energy stays smooth) and, for edges, its mollifier threshold.
  double boxPairWeight(const std::array<Index, 3>& cloth, int count) const;
  double boxPairEpsX(const BoxPair& pair, const Eigen::Matrix<double, 3, 4>& X) const;
  /// beginSubstep's lagged friction of the box pairs.
  void addBoxFriction(const VectorX& x0, double h, double gamma);
  /// Lagged friction of the point p of the cloth at the substep's start (a vertex, or a surface
  /// sample: the weighted sum of `count` vertices) against obstacle k, if k has friction and p is
  /// within dHat of it; mass: the m of the point's barrier kappa m b(d^2).
  void addObstacleFriction(std::size_t k, const Eigen::Vector3d& p, double mass, const Index* vertices,
                           const double* weights, int count, double h, double gamma);
  bool boxPairBarrier(const VectorX& x, const BoxPair& pair, bool wantGradient, bool wantHessian,
                      PairBarrier& out, double& distance, Eigen::Vector3d& point) const;
  /// The pairs whose box feature and cloth primitive (over x + t dx, t in [0, 1]; dx may be
  /// null) come within dHat of each other.
  void boxCandidates(const VectorX& x, const VectorX* dx, bool atEnd = true);
  /// prepareSegment's box part: the largest t <= tMax that CCD of the pairs allows (per DOF too).
  double boxSegment(const VectorX& x, const VectorX& dx, double tMax, VectorX* perDof);
  /// startingPoint's box part: marks in reached_ (2) the vertices of every triangle that a moving
  /// box comes within dHat of over the substep, the cloth held at x0.
  void markTrianglesBoxesReach(const VectorX& x0);
  /// The first triangle that overlaps a box at x (where it ends the substep), as a message; empty
  /// if none does.
  std::string boxCrossing(const VectorX& x) const;
  /// The same for box k alone, without its speed.
  std::string boxCrossing(const VectorX& x, std::size_t k) const;
  /// The world position of box k's corner i where the box ends (or starts) the substep.
  Eigen::Vector3d boxCorner(std::size_t k, int i, bool atEnd = true) const;
  std::vector<std::size_t> boxes_;  // the obstacles that are boxes
  std::vector<BoxPair> boxPairs_;
  std::vector<std::array<Index, 3>> boxPairCloth_;  // per pair: its cloth vertices (3 or 2)
  std::vector<Span> boxPairStencils_;
  VertexIncidence boxPairsOfVertex_;

  std::shared_ptr<const Mesh> mesh_;
  VectorX mass_;  // per vertex (kg)
  // Work storage of startingPoint() and finishSubstep(), kept to allocate nothing per step.
  VectorX startStep_, startFree_;
  const VectorX* substepStart_ = nullptr;  // finishSubstep's x0, for friction's loss
  std::vector<ObstacleWrench> finishWrench_;
  std::shared_ptr<ObstacleSet> obstacles_;
  ContactSettings settings_;
  double sHat_ = 0.0;
  double kappa_ = 0.0;
  double cellSize_ = 0.0;
  std::vector<std::array<Index, 2>> edges_;
  std::vector<double> restEdgeSquared_;
  // Round obstacles (spheres, capsules): the lattice points of the triangles that their barriers
  // also hold out (surface_samples.h), with k divisions, and each vertex's samples (sample, slot)
  // for vertexDerivatives. Empty without round obstacles.
  int divisions_ = 1;
  std::vector<SurfaceSample> samples_;
  std::vector<std::vector<std::pair<int, int>>> samplesOfVertex_;
  std::vector<char> round_;  // per obstacle: a sphere or capsule
  std::vector<char> reached_;  // startingPoint: vertex x obstacle, reached over the substep
  double substepLength_ = 0.0;  // s

  // The current substep.
  const std::vector<char>* pinned_ = nullptr;
  std::vector<std::pair<int, int>> pointTriangle_, edgeEdge_;
  std::vector<Friction> friction_;
  std::vector<char> carried_;  // per vertex: moved with an obstacle in the starting point
  // Per vertex: its self-contact pairs (point-triangle pairs first, then edge-edge) and its
  // friction entries, for vertexDerivatives; built by prepareVertexAccess, stale once the pairs
  // or the friction change.
  bool vertexTablesFresh_ = false;
  VertexIncidence pairsOfVertex_, frictionOfVertex_;
  std::vector<std::array<Index, 4>> pairStencils_;
  std::vector<Span> frictionStencils_;
  double frictionEps_ = 0.0;  // m: eps_v / gamma
  VectorX frictionOrigin_;    // xc: relative displacements are measured from it
  std::uint64_t checks_ = 0;  // self-contact distance evaluations
};

}  // namespace fem_cloth
