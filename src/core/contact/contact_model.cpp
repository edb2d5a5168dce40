#include "fem_cloth/core/contact/contact_model.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "fem_cloth/core/contact/barrier.h"
#include "fem_cloth/core/contact/box_features.h"
#include "fem_cloth/core/contact/broad_phase.h"
#include "fem_cloth/core/contact/ccd.h"
#include "fem_cloth/core/contact/edge_distance.h"
#include "fem_cloth/core/contact/primitive_distance.h"

namespace fem_cloth {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Clamps the negative eigenvalues of a symmetric matrix to zero (Li et al. 2020, section 4.3:
// each contact's Hessian is projected before assembly, so Newton directions descend).
Matrix12 projectPsd(const Matrix12& A) {
  const Eigen::SelfAdjointEigenSolver<Matrix12> eig(A);
  const Vector12 lambda = eig.eigenvalues().cwiseMax(0.0);
  return eig.eigenvectors() * lambda.asDiagonal() * eig.eigenvectors().transpose();
}

// An orthonormal basis of the plane normal to n (3 x 2).
Eigen::Matrix<double, 3, 2> tangentBasis(const Eigen::Vector3d& n) {
  const Eigen::Vector3d a = std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d t1 = (a - a.dot(n) * n).normalized();
  Eigen::Matrix<double, 3, 2> T;
  T << t1, n.cross(t1);
  return T;
}

Eigen::Vector3d vertex(const VectorX& x, Index i) { return x.segment<3>(3 * i); }

// "3, 4, 17": the vertices a surface sample lies between, for messages.
std::string vertexList(const SurfaceSample& sample) {
  std::string out = std::to_string(sample.vertices[0]);
  for (int j = 1; j < sample.count; ++j) out += ", " + std::to_string(sample.vertices[static_cast<std::size_t>(j)]);
  return out;
}

}  // namespace

ContactModel::ContactModel(const Model& model, std::shared_ptr<ObstacleSet> obstacles,
                           ContactSettings settings, double gravity)
    : mesh_(model.sharedMesh()),
      mass_(model.vertexMasses()),
      obstacles_(std::move(obstacles)),
      settings_(settings) {
  const double dHat = settings_.distance;
  sHat_ = dHat * dHat;
  // The barrier force on a vertex of mass m at distance d is kappa m |b'(d^2)| 2 d; at d = dHat/2
  // it is to be m times the stiffness acceleration.
  const double acceleration = settings_.stiffness > 0.0 ? settings_.stiffness : accelerationScale(gravity);
  kappa_ = acceleration / (std::abs(barrier::first(0.25 * sHat_, sHat_)) * dHat);
  edges_ = uniqueEdges(mesh_->triangles);
  double meanEdge = 0.0;
  for (const auto& e : edges_) {
    const double l2 = (vertex(mesh_->restPositions, e[0]) - vertex(mesh_->restPositions, e[1])).squaredNorm();
    restEdgeSquared_.push_back(l2);
    meanEdge += std::sqrt(l2);
  }
  meanEdge /= std::max<std::size_t>(edges_.size(), 1);
  sampleSurface(model);
  cellSize_ = std::max(meanEdge, 2.0 * dHat);
}

void ContactModel::sampleSurface(const Model& model) {
  // The lattice that keeps whole triangles out of the thinnest round obstacle, with the obstacle
  // grown by at most a quarter of dHat, for triangles stretched up to 50 % beyond their rest
  // shape (surface_samples.h); at most kMaxDivisions (an obstacle thin against the triangles
  // then grows by more). finishSubstep checks the promise exactly (surfaceCrossing).
  constexpr int kMaxDivisions = 24;
  const Mesh& mesh = *mesh_;
  round_.assign(obstacles_->size(), 0);
  double thinnest = kInf;
  for (std::size_t k = 0; k < obstacles_->size(); ++k) {
    if ((*obstacles_)[k].shape.type == ShapeType::Box) boxes_.push_back(k);
    if (!obstacles_->hasEdgeDistance(k)) continue;
    round_[k] = 1;
    thinnest = std::min(thinnest, (*obstacles_)[k].shape.radius);
  }
  if (thinnest == kInf) return;
  const double rho = settings_.surfaceStretch * largestRestLatticeRadius(mesh);
  const double grow = 0.25 * settings_.distance;
  const double rhoTarget = std::sqrt(grow * (2.0 * thinnest + grow));
  divisions_ = std::clamp(static_cast<int>(std::ceil(rho / rhoTarget)), 1, kMaxDivisions);
  for (std::size_t k = 0; k < obstacles_->size(); ++k) {
    if (round_[k]) obstacles_->setMargin(k, inflation((*obstacles_)[k].shape.radius, rho / divisions_));
  }
  samples_ = surfaceSamples(mesh, model.vertexMasses(), divisions_);
  samplesOfVertex_.assign(static_cast<std::size_t>(mesh.numVertices()), {});
  for (std::size_t j = 0; j < samples_.size(); ++j) {
    for (int slot = 0; slot < samples_[j].count; ++slot) {
      samplesOfVertex_[static_cast<std::size_t>(samples_[j].vertices[static_cast<std::size_t>(slot)])].emplace_back(
          static_cast<int>(j), slot);
    }
  }
}

std::string ContactModel::surfaceCrossing(const VectorX& x) const {
  for (std::size_t k = 0; k < obstacles_->size(); ++k) {
    const std::string crossing = surfaceCrossing(x, k);
    if (crossing.empty()) continue;
    char text[400];
    std::snprintf(text, sizeof text,
                  " (moving at %.3g m/s), although its surface samples (%d divisions) keep outside it grown by "
                  "%.3g mm: the triangle is stretched beyond the %.0f %% the lattice allows for "
                  "(contact.surface_stretch %.3g; a larger value takes more samples or grows the obstacles more)",
                  obstacleSpeed(k), divisions_, 1e3 * obstacles_->margin(k), 100.0 * (settings_.surfaceStretch - 1.0),
                  settings_.surfaceStretch);
    return crossing + text;
  }
  return {};
}

std::string ContactModel::surfaceCrossing(const VectorX& x, std::size_t k) const {
  if (!round_[k]) return {};
  {
    const Eigen::Isometry3d& inverse = obstacles_->inverseEnd(k);
    const Shape& shape = (*obstacles_)[k].shape;
    for (Index t = 0; t < mesh_->numTriangles(); ++t) {
      const Triangle& tri = mesh_->triangles[static_cast<std::size_t>(t)];
      if (!freeTriangle(tri)) continue;  // the pin wins
      // Every point of the triangle is within its longest side of a vertex: far from the
      // obstacle's bounding sphere, no exact distance is needed.
      const Eigen::Vector3d& w0 = vertex(x, tri[0]);
      const double side = std::sqrt(std::max({(vertex(x, tri[1]) - w0).squaredNorm(),
                                              (vertex(x, tri[2]) - vertex(x, tri[1])).squaredNorm(),
                                              (w0 - vertex(x, tri[2])).squaredNorm()}));
      if (roundLowerBound(k, w0) > side) continue;
      const Eigen::Vector3d a = inverse * vertex(x, tri[0]), b = inverse * vertex(x, tri[1]), c = inverse * vertex(x, tri[2]);
      const double d = *triangleShapeDistance(shape, a, b, c);
      if (d > 0.0) continue;
      char text[120];
      std::snprintf(text, sizeof text, ") reaches %.3g mm into obstacle '%s'", -1e3 * d, (*obstacles_)[k].name.c_str());
      return "triangle " + std::to_string(t) + " (vertices " + std::to_string(tri[0]) + ", " + std::to_string(tri[1]) +
             ", " + std::to_string(tri[2]) + text;
    }
  }
  return {};
}

void ContactModel::measureBoxDepth(const VectorX& x, ContactStats& stats) const {
  // A grid of n divisions per triangle (66 points): a lower bound of the depth, the depth of a
  // point being the distance it would have to move to leave the box, min_i (h_i - |p_i|).
  constexpr int n = 10;
  for (std::size_t k : boxes_) {
    const Shape& shape = (*obstacles_)[k].shape;
    const Eigen::Isometry3d& inverse = obstacles_->inverseEnd(k);
    for (Index t = 0; t < mesh_->numTriangles(); ++t) {
      const Triangle& tri = mesh_->triangles[static_cast<std::size_t>(t)];
      if (!freeTriangle(tri)) continue;  // the pin wins
      const Eigen::Vector3d a = inverse * vertex(x, tri[0]), b = inverse * vertex(x, tri[1]), c = inverse * vertex(x, tri[2]);
      if (box::beyondOneFace(shape.halfExtents, a, b, c)) continue;
      for (int i = 0; i <= n; ++i) {
        for (int j = 0; i + j <= n; ++j) {
          const double l0 = static_cast<double>(i) / n, l1 = static_cast<double>(j) / n;
          const Eigen::Vector3d p = l0 * a + l1 * b + (1.0 - l0 - l1) * c;
          const double depth = (shape.halfExtents - p.cwiseAbs()).minCoeff();
          if (depth <= stats.boxDepth) continue;
          stats.boxDepth = depth;
          stats.boxDepthWhere = "triangle " + std::to_string(t) + " in box '" + (*obstacles_)[k].name + "'";
        }
      }
    }
  }
}

Status ContactModel::checkSurfaceAtStart(const VectorX& x, const std::vector<Index>& pinned) {
  std::vector<char> fixed(static_cast<std::size_t>(x.size()), 0);
  for (Index v : pinned) fixed[static_cast<std::size_t>(3 * v)] = 1;
  pinned_ = &fixed;
  obstacles_->beginSubstep(0.0, 0.0);
  Status out = Status::success();
  for (std::size_t k : boxes_) {
    if (!(*obstacles_)[k].frame.empty() || !out.ok()) continue;
    const std::string crossing = boxCrossing(x, k);
    if (!crossing.empty()) {
      out = Error{"obstacles[" + std::to_string(k) + "] ('" + (*obstacles_)[k].name + "'): " + crossing +
                  " at the start; move the obstacle or the cloth"};
    }
  }
  for (std::size_t k = 0; k < obstacles_->size() && out.ok(); ++k) {
    if (!round_[k] || !(*obstacles_)[k].frame.empty()) continue;
    const std::string name = "obstacles[" + std::to_string(k) + "] ('" + (*obstacles_)[k].name + "')";
    const std::string crossing = surfaceCrossing(x, k);
    if (!crossing.empty()) {
      out = Error{name + ": " + crossing + " at the start; move the obstacle or the cloth"};
      break;
    }
    for (const SurfaceSample& sample : samples_) {
      if (!sampleTakesContact(sample) || obstacles_->distance(k, samplePoint(x, sample), false).distance > 0.0) continue;
      out = Error{name + ": the cloth between vertices " + vertexList(sample) + " starts within " +
                  std::to_string(1e3 * obstacles_->margin(k)) +
                  " mm of it, the margin by which the barriers grow round obstacles so that no point of a "
                  "triangle enters them (docs/contact.md); move the obstacle or the cloth farther apart"};
      break;
    }
  }
  pinned_ = nullptr;
  return out;
}

double ContactModel::minimumSelfDistance(const VectorX& x) {
  selfCandidates(x, nullptr);
  double smallest = kInf;
  for (const auto& [p, t] : pointTriangle_) {
    const Triangle& tri = mesh_->triangles[static_cast<std::size_t>(t)];
    ++checks_;
    smallest = std::min(smallest, pointTriangleDistance(vertex(x, p), vertex(x, tri[0]),
                                                        vertex(x, tri[1]), vertex(x, tri[2])).squared);
  }
  for (const auto& [a, b] : edgeEdge_) {
    const auto& ea = edges_[static_cast<std::size_t>(a)];
    const auto& eb = edges_[static_cast<std::size_t>(b)];
    ++checks_;
    smallest = std::min(smallest, edgeEdgeDistance(vertex(x, ea[0]), vertex(x, ea[1]),
                                                   vertex(x, eb[0]), vertex(x, eb[1])).squared);
  }
  return std::sqrt(smallest) < settings_.distance ? std::sqrt(smallest) : kInf;
}

// --- Self-contact broad phase ------------------------------------------------------------------

void ContactModel::selfCandidates(const VectorX& x, const VectorX* dx) {
  const Mesh& mesh = *mesh_;
  const Index n = mesh.numVertices();
  // Boxes over the motion, each inflated by dHat/2: two overlap when the primitives may come
  // within dHat of each other.
  auto box = [&](std::initializer_list<Index> vertices) {
    Aabb b;
    for (Index v : vertices) {
      b.extend(vertex(x, v));
      if (dx != nullptr) b.extend(vertex(x, v) + vertex(*dx, v));
    }
    b.inflate(0.5 * settings_.distance);
    return b;
  };
  std::vector<Aabb> points, triangles, edges;
  points.reserve(static_cast<std::size_t>(n));
  for (Index v = 0; v < n; ++v) points.push_back(box({v}));
  for (const Triangle& t : mesh.triangles) triangles.push_back(box({t[0], t[1], t[2]}));
  for (const auto& e : edges_) edges.push_back(box({e[0], e[1]}));
  // Pairs that share a vertex are never in contact: they touch by construction.
  overlappingPairs(points, triangles, false, cellSize_,
                   [&](int p, int t) {
                     const Triangle& tri = mesh.triangles[static_cast<std::size_t>(t)];
                     return tri[0] != p && tri[1] != p && tri[2] != p;
                   },
                   pointTriangle_);
  overlappingPairs(edges, edges, true, cellSize_,
                   [&](int a, int b) {
                     const auto& ea = edges_[static_cast<std::size_t>(a)];
                     const auto& eb = edges_[static_cast<std::size_t>(b)];
                     return ea[0] != eb[0] && ea[0] != eb[1] && ea[1] != eb[0] && ea[1] != eb[1];
                   },
                   edgeEdge_);
  vertexTablesFresh_ = false;
}

double ContactModel::edgeMollifierThreshold(Index ea, Index eb) const {
  // Li et al. 2020, section 4.3: eps_x = 1e-3 |ea_rest|^2 |eb_rest|^2.
  return 1e-3 * restEdgeSquared_[static_cast<std::size_t>(ea)] *
         restEdgeSquared_[static_cast<std::size_t>(eb)];
}

// --- Implicit steppers -------------------------------------------------------------------------

void ContactModel::beginSubstep(const VectorX& x0, const VectorX& xc, double gamma, double h,
                                const std::vector<char>& pinned, double f0, double f1) {
  pinned_ = &pinned;
  substepLength_ = h;
  obstacles_->beginSubstep(f0, f1);
  friction_.clear();
  frictionEps_ = settings_.frictionVelocity / gamma;
  // Lagged friction (Li et al. 2020, section 5.3): the normal force lambda of every contact at
  // the start of the substep, its tangent plane and the relative motion of the two sides.
  for (Index i = 0; i < mesh_->numVertices(); ++i) {
    if (!isFree(i)) continue;
    const double one = 1.0;
    for (std::size_t k = 0; k < obstacles_->size(); ++k) {
      addObstacleFriction(k, vertex(x0, i), mass_[i], &i, &one, 1, h, gamma);
    }
  }
  // The surface samples against round obstacles, as their barriers (addSampleBarriers): the
  // sample point slides, its friction force splits over its vertices by the weights.
  for (const SurfaceSample& s : samples_) {
    if (!sampleTakesContact(s)) continue;
    const Eigen::Vector3d p = samplePoint(x0, s);
    for (std::size_t k = 0; k < obstacles_->size(); ++k) {
      if (!round_[k] || !((*obstacles_)[k].friction > 0.0)) continue;  // no bound for no friction
      const Shape& shape = (*obstacles_)[k].shape;
      const double far = (p - obstacles_->poseStart(k).translation()).norm() -
                         (shape.radius + shape.halfLength + obstacles_->margin(k));
      if (far >= settings_.distance) continue;
      addObstacleFriction(k, p, s.mass, s.vertices.data(), s.weights.data(), s.count, h, gamma);
    }
  }
  if (!boxes_.empty()) addBoxFriction(x0, h, gamma);
  if (settings_.selfCollision && settings_.selfFriction > 0.0) {
    selfCandidates(x0, nullptr);
    auto add = [&](const PrimitiveDistance& pd, std::array<Index, 4> v, double weight,
                   double mollified) {
      ++checks_;
      if (!(pd.squared > 0.0 && pd.squared < sHat_)) return;
      const double d = std::sqrt(pd.squared);
      Friction f;
      f.vertices = v;
      f.count = 4;
      f.weights = pd.weights;
      f.tangent = tangentBasis(pd.r / d);
      f.muLambda = settings_.selfFriction * kappa_ * weight * mollified *
                   std::abs(barrier::first(pd.squared, sHat_)) * 2.0 * d;
      friction_.push_back(f);
    };
    for (const auto& [p, t] : pointTriangle_) {
      const Triangle& tri = mesh_->triangles[static_cast<std::size_t>(t)];
      add(pointTriangleDistance(vertex(x0, p), vertex(x0, tri[0]), vertex(x0, tri[1]), vertex(x0, tri[2])),
          {p, tri[0], tri[1], tri[2]}, mass_[p], 1.0);
    }
    for (const auto& [a, b] : edgeEdge_) {
      const auto& ea = edges_[static_cast<std::size_t>(a)];
      const auto& eb = edges_[static_cast<std::size_t>(b)];
      const double c = edgeCrossSquared(vertex(x0, ea[0]), vertex(x0, ea[1]), vertex(x0, eb[0]), vertex(x0, eb[1]));
      add(edgeEdgeDistance(vertex(x0, ea[0]), vertex(x0, ea[1]), vertex(x0, eb[0]), vertex(x0, eb[1])),
          {ea[0], ea[1], eb[0], eb[1]},
          0.25 * (mass_[ea[0]] + mass_[ea[1]] + mass_[eb[0]] + mass_[eb[1]]),
          mollifier::value(c, edgeMollifierThreshold(a, b)));
    }
  }
  // The relative displacement of a friction contact is measured from xc.
  frictionOrigin_ = xc;
  vertexTablesFresh_ = false;
}

void ContactModel::addObstacleFriction(std::size_t k, const Eigen::Vector3d& p, double mass,
                                       const Index* vertices, const double* weights, int count,
                                       double h, double gamma) {
  if (!((*obstacles_)[k].friction > 0.0)) return;
  const SignedDistance sd = obstacles_->distance(k, p, false);
  if (!(sd.distance > 0.0 && sd.distance < settings_.distance)) return;
  Friction f;
  f.count = count;
  for (int i = 0; i < count; ++i) {
    f.vertices[static_cast<std::size_t>(i)] = vertices[i];
    f.weights[i] = weights[i];
  }
  f.tangent = tangentBasis(sd.normal);
  // The obstacle's surface point under the point moves with the obstacle; relative to it the
  // point slides. Velocity is gamma (x - xc), so the obstacle's displacement enters divided by
  // h gamma (1 for backward Euler).
  const Eigen::Vector3d moved = obstacles_->poseEnd(k) * (obstacles_->inverseStart(k) * sd.closest);
  f.offset = (moved - sd.closest) / (h * gamma);
  // The normal force of the point's barrier kappa m b(d^2) there.
  const double s = sd.distance * sd.distance;
  f.muLambda = (*obstacles_)[k].friction * kappa_ * mass * std::abs(barrier::first(s, sHat_)) * 2.0 * sd.distance;
  f.obstacle = static_cast<int>(k);
  f.point = moved;
  friction_.push_back(f);
}

void ContactModel::addBoxFriction(const VectorX& x0, double h, double gamma) {
  // Lagged friction of the box pairs closer than dHat at x0 (the boxes where they start the
  // substep), as the vertices' (beginSubstep): the cloth's closest point (its weights) slides
  // against the box's, which moves with the box.
  boxCandidates(x0, nullptr, false);
  Eigen::Matrix<double, 3, 4> X;
  std::array<Index, 3> cloth{};
  for (const BoxPair& pair : boxPairs_) {
    const auto k = static_cast<std::size_t>(pair.box);
    if (!((*obstacles_)[k].friction > 0.0)) continue;
    ++checks_;
    const int count = boxPairPoints(x0, pair, X, cloth, false);
    const PrimitiveDistance pd = pair.edgeEdge ? edgeEdgeDistance(X.col(0), X.col(1), X.col(2), X.col(3))
                                               : pointTriangleDistance(X.col(0), X.col(1), X.col(2), X.col(3));
    if (!(pd.squared > 0.0 && pd.squared < sHat_)) continue;
    const int first = 4 - count;  // the cloth's slots
    Friction f;
    f.count = count;
    Eigen::Vector3d closest = Eigen::Vector3d::Zero();  // the box's point (weights of its slots)
    for (int i = 0; i < first; ++i) closest += pd.weights[i] * X.col(i);
    for (int i = 0; i < count; ++i) {
      f.vertices[static_cast<std::size_t>(i)] = cloth[static_cast<std::size_t>(i)];
      f.weights[i] = -pd.weights[first + i];  // r = box point - cloth point
    }
    const double d = std::sqrt(pd.squared);
    f.tangent = tangentBasis(pd.r / d);
    const Eigen::Vector3d moved = obstacles_->poseEnd(k) * (obstacles_->inverseStart(k) * closest);
    f.offset = (moved - closest) / (h * gamma);
    // The normal force of the pair's barrier there (mollified for edges).
    const double mollified =
        pair.edgeEdge ? mollifier::value(edgeCrossSquared(X.col(0), X.col(1), X.col(2), X.col(3)), boxPairEpsX(pair, X))
                      : 1.0;
    f.muLambda = (*obstacles_)[k].friction * boxPairWeight(cloth, count) * mollified *
                 std::abs(barrier::first(pd.squared, sHat_)) * 2.0 * d;
    f.obstacle = static_cast<int>(k);
    f.point = moved;
    friction_.push_back(f);
  }
}

bool ContactModel::obstacleReaches(std::size_t k, const Eigen::Vector3d& p) {
  ObstacleSet& obstacles = *obstacles_;
  const Eigen::Isometry3d &start = obstacles.poseStart(k), &end = obstacles.poseEnd(k);
  if (start.matrix() == end.matrix()) return false;
  // In the obstacle's frame a point moves along inverse(pose(t)) p: its speed is at most
  // |shift| + angle |p - centre| (centre anywhere on the way).
  const Eigen::Vector3d shift = end.translation() - start.translation();
  const double angle = Eigen::AngleAxisd(start.linear().transpose() * end.linear()).angle();
  const double lp = shift.norm() + angle * ((p - start.translation()).norm() + shift.norm());
  auto distanceAt = [&](double t) {
    return obstacles.shapeDistance(k, interpolatePose(start, end, t).inverse() * p).distance;
  };
  return ccd::comesWithin(distanceAt, distanceAt(0.0), lp, settings_.distance);
}

double ContactModel::obstacleSpeed(std::size_t k) const {
  const double shift = (obstacles_->poseEnd(k).translation() - obstacles_->poseStart(k).translation()).norm();
  return substepLength_ > 0.0 ? shift / substepLength_ : 0.0;
}

std::string ContactModel::movingObstaclesText() const {
  std::string out;
  for (std::size_t k = 0; k < obstacles_->size(); ++k) {
    const double shift = (obstacles_->poseEnd(k).translation() - obstacles_->poseStart(k).translation()).norm();
    if (!(shift > 0.0)) continue;
    char text[160];
    std::snprintf(text, sizeof text, "' moves at %.3g m/s (%.3g mm in the substep, %.3g contact.distance)",
                  obstacleSpeed(k), 1e3 * shift, shift / settings_.distance);
    out += (out.empty() ? "obstacle '" : "; obstacle '") + (*obstacles_)[k].name + text;
  }
  return out;
}

std::size_t ContactModel::carryingObstacle(const Eigen::Vector3d& p, const char* reached) {
  ObstacleSet& obstacles = *obstacles_;
  // The smallest distance to any obstacle at the end of the substep if p moves to q.
  auto clearance = [&](const Eigen::Vector3d& q) {
    double smallest = kInf;
    for (std::size_t k = 0; k < obstacles.size(); ++k) smallest = std::min(smallest, obstacles.distance(k, q, true).distance);
    return smallest;
  };
  std::size_t best = obstacles.size();
  double bestClearance = -kInf;
  bool any = false, mayStay = true;
  for (std::size_t k = 0; k < obstacles.size(); ++k) mayStay = mayStay && reached[k] != 2;
  for (std::size_t k = 0; k < obstacles.size(); ++k) {
    if (reached[k] == 0) continue;
    if (!any && mayStay) bestClearance = clearance(p);  // staying where it is
    any = true;
    const double c = clearance(obstacles.poseEnd(k) * (obstacles.inverseStart(k) * p));
    if (c > bestClearance) {
      best = k;
      bestClearance = c;
    }
  }
  return best;
}

Status ContactModel::startingPoint(const VectorX& x0, const VectorX& wanted, VectorX& x) {
  const Index n = mesh_->numVertices();
  x = x0;
  // Each free vertex that a moving obstacle comes to within dHat of moves with one of them
  // (rigidly, which keeps its distance), once: between two fingers that move together it is
  // carried by one, not by both in turn (which put it the fingers' displacement too close to
  // the second and made Newton climb back out of its barrier: 3-5 times the iterations of a
  // pinch-lift substep).
  // A vertex is a candidate for each obstacle that comes within dHat of it (1) or of a surface
  // sample of one of its triangles (2: a triangle that a round obstacle would cross between its
  // vertices moves with it; then the vertex may not stay, however far staying leaves the vertex).
  carried_.assign(static_cast<std::size_t>(n), 0);
  const std::size_t obstacleCount = obstacles_->size();
  reached_.assign(static_cast<std::size_t>(n) * obstacleCount, 0);
  for (Index i = 0; i < n; ++i) {
    if (!isFree(i)) continue;
    for (std::size_t k = 0; k < obstacleCount; ++k) {
      if (obstacleReaches(k, vertex(x0, i))) reached_[static_cast<std::size_t>(i) * obstacleCount + k] = 1;
    }
  }
  for (const SurfaceSample& sample : samples_) {
    if (!sampleTakesContact(sample)) continue;
    for (std::size_t k = 0; k < obstacleCount; ++k) {
      if (!round_[k] || !obstacleReaches(k, samplePoint(x0, sample))) continue;
      for (int j = 0; j < sample.count; ++j) {
        reached_[static_cast<std::size_t>(sample.vertices[static_cast<std::size_t>(j)]) * obstacleCount + k] = 2;
      }
    }
  }
  if (!boxes_.empty()) markTrianglesBoxesReach(x0);
  for (Index i = 0; i < n; ++i) {
    if (!isFree(i)) continue;
    const std::size_t k = carryingObstacle(vertex(x0, i), &reached_[static_cast<std::size_t>(i) * obstacleCount]);
    if (k < obstacles_->size()) {
      x.segment<3>(3 * i) = obstacles_->poseEnd(k) * (obstacles_->inverseStart(k) * vertex(x0, i));
      carried_[static_cast<std::size_t>(i)] = 1;
    }
  }
  for (Index i = 0; i < n; ++i) {
    if (!isFree(i)) continue;
    for (std::size_t k = 0; k < obstacles_->size(); ++k) {
      const double d = obstacles_->distance(k, vertex(x, i), true).distance;
      if (!(d > 0.0)) {
        return Error{"vertex " + std::to_string(i) + " would be inside obstacle '" +
                     (*obstacles_)[k].name + "' (" + std::to_string(d) + " m; the obstacle moves at " +
                     std::to_string(obstacleSpeed(k)) +
                     " m/s): pinched between obstacles, pushed in by a pin, or the obstacle moves "
                     "farther in a substep than the cloth can follow (more substeps may help)"};
      }
    }
  }
  for (const SurfaceSample& sample : samples_) {
    if (!sampleTakesContact(sample)) continue;
    for (std::size_t k = 0; k < obstacles_->size(); ++k) {
      if (!round_[k]) continue;
      const double d = obstacles_->distance(k, samplePoint(x, sample), true).distance;
      if (!(d > 0.0)) {
        return Error{"a point between vertices " + vertexList(sample) + " would be inside obstacle '" + (*obstacles_)[k].name +
                     "' (" + std::to_string(d) + " m; the obstacle moves at " + std::to_string(obstacleSpeed(k)) +
                     " m/s): pinched between obstacles, pushed in by a pin, or the obstacle moves "
                     "farther in a substep than the cloth can follow (more substeps may help)"};
      }
    }
  }
  if (const std::string crossing = boxCrossing(x); !crossing.empty()) {
    return Error{crossing + " where the obstacles carried the cloth: pinched between obstacles, or the obstacle "
                 "moves farther in a substep than the cloth can follow (more substeps may help)"};
  }
  if (settings_.selfCollision && x != x0 && prepareSegment(x0, x - x0, false) < 1.0) {
    return Error{"an obstacle's motion in this step would pass the cloth through itself"};
  }
  // Everything at once: pins to their targets, free vertices by their own wanted motion, except
  // those an obstacle carries: they have moved with it already (their own velocity, about the
  // obstacle's, on top of the carry put a pinched vertex h |v| into the pad's barrier).
  VectorX& step = startStep_;
  step.resize(x.size());
  for (Eigen::Index d = 0; d < x.size(); ++d) {
    if ((*pinned_)[d]) {
      step[d] = wanted[d] - x[d];
    } else {
      step[d] = carried_[static_cast<std::size_t>(d / 3)] ? 0.0 : wanted[d] - x0[d];
    }
  }
  if (prepareSegment(x, step) >= 1.0) {
    x += step;
    return Status::success();
  }
  // Else the pins first, the free vertices staying, then the free vertices as far as is safe.
  VectorX& free = startFree_;
  free = step;
  for (Eigen::Index d = 0; d < x.size(); ++d) ((*pinned_)[d] ? free[d] : step[d]) = 0.0;
  if (prepareSegment(x, step) < 1.0) {
    return Error{"the pins' motion in this step would pass the cloth through itself"};
  }
  x += step;
  x += prepareSegment(x, free) * free;
  return Status::success();
}

double ContactModel::prepareSegment(const VectorX& x, const VectorX& dx, bool withObstacles,
                                    VectorX* perDof) {
  // Each vertex's own bound: t found with the cap 1 instead of the running minimum (additive CCD
  // advances the same way under any cap, so the minimum, the whole step's t, is the same bits).
  auto lower = [&](Index v, double t) {
    if (perDof != nullptr) perDof->segment<3>(3 * v) = perDof->segment<3>(3 * v).cwiseMin(t);
  };
  double t = 1.0;
  // The largest t <= cap at which the point p moving by `step` stays clear of the obstacles
  // (only the round ones if roundOnly).
  auto pointBound = [&](const Eigen::Vector3d& p, const Eigen::Vector3d& step, bool roundOnly) {
    const double length = step.norm();
    double ti = perDof != nullptr ? 1.0 : t;
    if (length == 0.0) return ti;
    for (std::size_t k = 0; k < obstacles_->size(); ++k) {
      if (roundOnly && (!round_[k] || length * ti < (1.0 - ccd::kRescaling) * roundLowerBound(k, p))) continue;
      const double d0 = obstacles_->distance(k, p, true).distance;
      // A point cannot lose more distance than it moves.
      if (length * ti < (1.0 - ccd::kRescaling) * d0) continue;
      auto at = [&](double s) { return obstacles_->distance(k, p + s * step, true).distance; };
      ti = std::min(ti, ccd::additive(at, d0, length, ti));
    }
    return ti;
  };
  const Index n = withObstacles ? mesh_->numVertices() : 0;
  for (Index i = 0; i < n; ++i) {
    if (!isFree(i)) continue;
    const double ti = pointBound(vertex(x, i), vertex(dx, i), false);
    lower(i, ti);
    t = std::min(t, ti);
  }
  for (std::size_t j = 0; withObstacles && j < samples_.size(); ++j) {
    const SurfaceSample& sample = samples_[j];
    if (!sampleTakesContact(sample)) continue;
    const double tj = pointBound(samplePoint(x, sample), samplePoint(dx, sample), true);
    for (int v = 0; v < sample.count; ++v) lower(sample.vertices[static_cast<std::size_t>(v)], tj);
    t = std::min(t, tj);
  }
  if (withObstacles && !boxes_.empty()) t = std::min(t, boxSegment(x, dx, t, perDof));
  if (settings_.selfCollision) t = std::min(t, selfSegment(x, dx, t, perDof));
  return t;
}

double ContactModel::selfSegment(const VectorX& x, const VectorX& dx, double tMax, VectorX* perDof) {
  const bool moving = dx.size() == x.size() && !dx.isZero();
  selfCandidates(x, moving ? &dx : nullptr);
  if (!moving) return tMax;
  double t = tMax;
  Eigen::Matrix<double, 3, 4> X, D;
  auto pair = [&](std::array<Index, 4> v, auto ccdOf) {
    for (int c = 0; c < 4; ++c) {
      X.col(c) = vertex(x, v[static_cast<std::size_t>(c)]);
      D.col(c) = vertex(dx, v[static_cast<std::size_t>(c)]);
    }
    ++checks_;
    const double tp = ccdOf(X, D, perDof != nullptr ? 1.0 : t);
    if (perDof != nullptr) {
      for (Index vertexIndex : v) perDof->segment<3>(3 * vertexIndex) = perDof->segment<3>(3 * vertexIndex).cwiseMin(tp);
    }
    t = std::min(t, tp);
  };
  for (const auto& [p, tIndex] : pointTriangle_) {
    const Triangle& tri = mesh_->triangles[static_cast<std::size_t>(tIndex)];
    pair({p, tri[0], tri[1], tri[2]}, [](const auto& A, const auto& B, double c) { return ccd::pointTriangle(A, B, c); });
  }
  for (const auto& [a, b] : edgeEdge_) {
    const auto& ea = edges_[static_cast<std::size_t>(a)];
    const auto& eb = edges_[static_cast<std::size_t>(b)];
    pair({ea[0], ea[1], eb[0], eb[1]}, [](const auto& A, const auto& B, double c) { return ccd::edgeEdge(A, B, c); });
  }
  return t;
}

void ContactModel::addBlock(Index a, Index b, const Eigen::Matrix3d& block, SparseHessian* hessian,
                            std::vector<Eigen::Triplet<double>>* outside) const {
  double* values = hessian->values();
  for (int l = 0; l < 3; ++l) {
    const int offset = hessian->blockColumnOffset(a, b, l);
    for (int k = 0; k < 3; ++k) {
      if (offset >= 0) {
        values[offset + k] += block(k, l);
      } else if (outside != nullptr) {
        outside->emplace_back(3 * a + k, 3 * b + l, block(k, l));
      }
    }
  }
}

double ContactModel::evaluate(const VectorX& x, VectorX* gradient, SparseHessian* hessian,
                              std::vector<Eigen::Triplet<double>>* outside, double scale, Part part,
                              double energyStart) {
  return evaluateAll(x, gradient, hessian, outside, scale, nullptr, nullptr, part, energyStart);
}

void ContactModel::Assembly::note(double distance, double dHat) {
  if (stats == nullptr) return;
  stats->minDistance = std::min(stats->minDistance, distance);
  if (distance < dHat) ++stats->contacts;
}

void ContactModel::scatter(const std::array<Index, 4>& v, const Vector12& g, const Matrix12* H,
                           Assembly& a) const {
  // H: already positive semi-definite.
  if (a.gradient != nullptr) {
    for (int k = 0; k < 4; ++k) a.gradient->segment<3>(3 * v[k]) += a.scale * g.segment<3>(3 * k);
  }
  if (H != nullptr) {
    for (int k = 0; k < 4; ++k) {
      for (int l = 0; l < 4; ++l) {
        addBlock(v[k], v[l], a.scale * H->block<3, 3>(3 * k, 3 * l), a.hessian, a.outside);
      }
    }
  }
}

double ContactModel::evaluateAll(const VectorX& x, VectorX* gradient, SparseHessian* hessian,
                                 std::vector<Eigen::Triplet<double>>* outside, double scale,
                                 std::vector<ObstacleWrench>* wrench, ContactStats* stats,
                                 Part part, double energyStart) {
  Assembly a;
  a.gradient = gradient;
  a.hessian = hessian;
  a.outside = outside;
  a.scale = scale;
  a.wrench = wrench;
  a.stats = stats;
  a.energy = energyStart;
  // One running sum over barriers, then friction, in this order.
  if (part != Part::Friction) {
    if (!addObstacleBarriers(x, a)) return kInf;
    if (!samples_.empty() && !addSampleBarriers(x, a)) return kInf;
    if (!boxPairs_.empty() && !addBoxPairBarriers(x, a)) return kInf;
    if (settings_.selfCollision && !(addPointTriangleBarriers(x, a) && addEdgeEdgeBarriers(x, a))) {
      return kInf;
    }
    if (stats != nullptr) stats->stored = a.energy - energyStart;
  }
  if (part != Part::Barriers) addFriction(x, a);
  return a.energy;
}

bool ContactModel::addObstacleBarriers(const VectorX& x, Assembly& a) {
  // Vertex-obstacle barriers: kappa m b(d^2), d the signed distance at the end of the substep.
  const double dHat = settings_.distance;
  for (Index i = 0; i < mesh_->numVertices(); ++i) {
    if (!isFree(i)) continue;
    for (std::size_t k = 0; k < obstacles_->size(); ++k) {
      const SignedDistance sd = obstacles_->distance(k, vertex(x, i), true);
      a.note(sd.distance, dHat);
      if (!(sd.distance > 0.0)) return false;
      if (sd.distance >= dHat) continue;
      const VertexBarrier b = vertexBarrier(i, sd);
      a.energy += b.energy;
      const Eigen::Vector3d& g = b.gradient;
      if (a.gradient != nullptr) a.gradient->segment<3>(3 * i) += a.scale * g;
      if (a.wrench != nullptr) {
        (*a.wrench)[k].force += g;  // the cloth pushes the obstacle with +dE/dx
        (*a.wrench)[k].torque += sd.closest.cross(g);
      }
      // The obstacle's work: the force on the cloth, -g, times the motion of its surface point.
      if (a.stats != nullptr) a.stats->work -= g.dot(surfaceMotion(k, sd.closest));
      if (a.hessian != nullptr) {
        addBlock(i, i, (a.scale * b.weight * b.along) * (sd.normal * sd.normal.transpose()),
                 a.hessian, a.outside);
      }
    }
  }
  return true;
}

bool ContactModel::addSampleBarriers(const VectorX& x, Assembly& a) {
  // Surface samples against the round obstacles (grown by their margins): kappa m_s b(d^2) as a
  // vertex's, d the sample point's distance; its gradient splits over its vertices by the weights.
  const double dHat = settings_.distance;
  for (const SurfaceSample& s : samples_) {
    if (!sampleTakesContact(s)) continue;
    const Eigen::Vector3d p = samplePoint(x, s);
    for (std::size_t k = 0; k < obstacles_->size(); ++k) {
      if (!round_[k] || roundLowerBound(k, p) >= dHat) continue;
      const SignedDistance sd = obstacles_->distance(k, p, true);
      a.note(sd.distance, dHat);
      if (!(sd.distance > 0.0)) return false;
      if (sd.distance >= dHat) continue;
      const VertexBarrier b = massBarrier(kappa_ * s.mass, sd);
      a.energy += b.energy;
      if (a.gradient != nullptr) {
        for (int i = 0; i < s.count; ++i) a.gradient->segment<3>(3 * s.vertices[static_cast<std::size_t>(i)]) += (a.scale * s.weights[i]) * b.gradient;
      }
      if (a.wrench != nullptr) {
        (*a.wrench)[k].force += b.gradient;
        (*a.wrench)[k].torque += sd.closest.cross(b.gradient);
      }
      if (a.stats != nullptr) a.stats->work -= b.gradient.dot(surfaceMotion(k, sd.closest));
      if (a.hessian != nullptr) {
        const Eigen::Matrix3d nn = (a.scale * b.weight * b.along) * (sd.normal * sd.normal.transpose());
        for (int r = 0; r < s.count; ++r) {
          for (int c = 0; c < s.count; ++c) {
            addBlock(s.vertices[static_cast<std::size_t>(r)], s.vertices[static_cast<std::size_t>(c)],
                     (s.weights[r] * s.weights[c]) * nn, a.hessian, a.outside);
          }
        }
      }
    }
  }
  return true;
}

ContactModel::VertexBarrier ContactModel::vertexBarrier(Index i, const SignedDistance& sd) const {
  return massBarrier(kappa_ * mass_[i], sd);
}

ContactModel::VertexBarrier ContactModel::massBarrier(double w, const SignedDistance& sd) const {
  // w b(d^2) with w = kappa m, d the signed distance (0 < d < dHat).
  VertexBarrier out;
  const double d = sd.distance, s = d * d;
  out.energy = w * barrier::value(s, sHat_);
  const double b1 = barrier::first(s, sHat_);
  out.gradient = w * b1 * 2.0 * d * sd.normal;
  // With s = d^2: d2s = 2 n n^T + 2 d Hd, and the Hessian is
  //   w ((4 b'' s + 2 b') n n^T + 2 b' d Hd).
  // An exact distance has |grad d| = 1, so Hd n = 0, and outside a convex shape Hd is positive
  // semi-definite: its part (times b' < 0) is negative across the normal, and the PSD
  // projection keeps the normal part alone (the same as barrierGaussNewtonHessian).
  out.weight = w;
  out.along = std::max(4.0 * barrier::second(s, sHat_) * s + 2.0 * b1, 0.0);
  return out;
}

bool ContactModel::addPointTriangleBarriers(const VectorX& x, Assembly& a) {
  const bool wantHessian = a.hessian != nullptr;
  const bool wantGradient = a.wantsGradient();
  PairBarrier b;
  double distance = 0.0;
  for (const auto& [p, t] : pointTriangle_) {
    const Triangle& tri = mesh_->triangles[static_cast<std::size_t>(t)];
    ++checks_;
    const bool ok = pointTriangleBarrier(x, p, t, wantGradient, wantHessian, b, distance);
    a.note(distance, settings_.distance);
    if (!ok) return false;
    if (!b.active) continue;
    a.energy += b.energy;
    if (!wantGradient) continue;
    scatter({p, tri[0], tri[1], tri[2]}, b.gradient, wantHessian ? &b.hessian : nullptr, a);
  }
  return true;
}

bool ContactModel::pointTriangleBarrier(const VectorX& x, int p, int t, bool wantGradient,
                                        bool wantHessian, PairBarrier& out,
                                        double& distance) const {
  const Triangle& tri = mesh_->triangles[static_cast<std::size_t>(t)];
  Eigen::Matrix<double, 3, 4> X;
  X << vertex(x, p), vertex(x, tri[0]), vertex(x, tri[1]), vertex(x, tri[2]);
  PrimitiveDistance pd;
  return pairBarrier(X, false, kappa_ * mass_[p], 0.0, wantGradient, wantHessian, out, distance, pd);
}

bool ContactModel::pairBarrier(const Eigen::Matrix<double, 3, 4>& X, bool edgeEdge, double w, double epsX,
                               bool wantGradient, bool wantHessian, PairBarrier& out, double& distance,
                               PrimitiveDistance& pd) const {
  Vector12 gs, gc;
  Matrix12 Hs, Hc;
  const bool exactHessian = wantHessian && edgeEdge;  // the mollified product rule needs it
  pd = edgeEdge ? edgeEdgeDistance(X.col(0), X.col(1), X.col(2), X.col(3), wantGradient ? &gs : nullptr,
                                   exactHessian ? &Hs : nullptr)
                : pointTriangleDistance(X.col(0), X.col(1), X.col(2), X.col(3), wantGradient ? &gs : nullptr);
  distance = std::sqrt(pd.squared);
  out.active = false;
  if (!(pd.squared > 0.0)) return false;
  if (pd.squared >= sHat_) return true;
  out.active = true;
  // Edge-edge: mollified, e(c) b(s) with c = |ea x eb|^2 fading nearly parallel edges (section 4.3).
  const double c = edgeEdge ? edgeCrossSquared(X.col(0), X.col(1), X.col(2), X.col(3), wantGradient ? &gc : nullptr,
                                               exactHessian ? &Hc : nullptr)
                            : 0.0;
  const double e = edgeEdge ? mollifier::value(c, epsX) : 1.0, bv = barrier::value(pd.squared, sHat_);
  out.energy = w * e * bv;
  if (!wantGradient) return true;
  const double b1 = barrier::first(pd.squared, sHat_);
  if (e == 1.0) {
    if (wantHessian) out.hessian = w * barrierGaussNewtonHessian(pd, b1, barrier::second(pd.squared, sHat_));
    // (The two products in the order each pair had before they shared this code: the same bits.)
    out.gradient = edgeEdge ? Vector12(w * (b1 * gs)) : Vector12(w * b1 * gs);
    return true;
  }
  const double e1 = mollifier::first(c, epsX);
  const Vector12 gb = b1 * gs, ge = e1 * gc;
  if (wantHessian) {
    // Nearly parallel edges (rare): the product rule, projected by eigen-decomposition.
    out.hessian = projectPsd(w * (e * (barrier::second(pd.squared, sHat_) * gs * gs.transpose() + b1 * Hs) +
                                  gb * ge.transpose() + ge * gb.transpose() +
                                  bv * (mollifier::second(c, epsX) * gc * gc.transpose() + e1 * Hc)));
  }
  out.gradient = w * (e * gb + bv * ge);
  return true;
}

bool ContactModel::addEdgeEdgeBarriers(const VectorX& x, Assembly& a) {
  const bool wantHessian = a.hessian != nullptr;
  const bool wantGradient = a.wantsGradient();
  PairBarrier b;
  double distance = 0.0;
  for (const auto& [ia, ib] : edgeEdge_) {
    const auto& ea = edges_[static_cast<std::size_t>(ia)];
    const auto& eb = edges_[static_cast<std::size_t>(ib)];
    ++checks_;
    const bool ok = edgeEdgeBarrier(x, ia, ib, wantGradient, wantHessian, b, distance);
    a.note(distance, settings_.distance);
    if (!ok) return false;
    if (!b.active) continue;
    a.energy += b.energy;
    if (!wantGradient) continue;
    scatter({ea[0], ea[1], eb[0], eb[1]}, b.gradient, wantHessian ? &b.hessian : nullptr, a);
  }
  return true;
}

bool ContactModel::edgeEdgeBarrier(const VectorX& x, int ia, int ib, bool wantGradient,
                                   bool wantHessian, PairBarrier& out, double& distance) const {
  const auto& ea = edges_[static_cast<std::size_t>(ia)];
  const auto& eb = edges_[static_cast<std::size_t>(ib)];
  Eigen::Matrix<double, 3, 4> X;
  X << vertex(x, ea[0]), vertex(x, ea[1]), vertex(x, eb[0]), vertex(x, eb[1]);
  const double w = kappa_ * 0.25 * (mass_[ea[0]] + mass_[ea[1]] + mass_[eb[0]] + mass_[eb[1]]);
  PrimitiveDistance pd;
  return pairBarrier(X, true, w, edgeMollifierThreshold(ia, ib), wantGradient, wantHessian, out, distance, pd);
}

void ContactModel::addFriction(const VectorX& x, Assembly& a) const {
  for (const Friction& f : friction_) {
    const FrictionShare share = frictionShare(f, x, a.hessian != nullptr);
    a.energy += share.energy;
    const Eigen::Vector3d& g = share.gradient;
    if (a.gradient != nullptr) {
      for (int k = 0; k < f.count; ++k) {
        a.gradient->segment<3>(3 * f.vertices[static_cast<std::size_t>(k)]) += a.scale * f.weights[k] * g;
      }
    }
    if (a.wrench != nullptr && f.obstacle >= 0) {
      (*a.wrench)[static_cast<std::size_t>(f.obstacle)].force += g;
      (*a.wrench)[static_cast<std::size_t>(f.obstacle)].torque += f.point.cross(g);
    }
    if (a.stats != nullptr) addFrictionWork(f, x, g, *a.stats);
    if (a.hessian != nullptr) {
      for (int k = 0; k < f.count; ++k) {
        for (int l = 0; l < f.count; ++l) {
          addBlock(f.vertices[static_cast<std::size_t>(k)], f.vertices[static_cast<std::size_t>(l)],
                   a.scale * f.weights[k] * f.weights[l] * share.hessian, a.hessian, a.outside);
        }
      }
    }
  }
}

Eigen::Vector3d ContactModel::surfaceMotion(std::size_t k, const Eigen::Vector3d& p) const {
  return p - obstacles_->poseStart(k) * (obstacles_->inverseEnd(k) * p);
}

void ContactModel::addFrictionWork(const Friction& f, const VectorX& x, const Eigen::Vector3d& g,
                                   ContactStats& stats) const {
  // The force -g acts on the weighted point sum_k w_k x_k of the contact; the other side (the
  // obstacle's surface point, or the cloth's other primitive, in the weights) moved by `other`.
  Eigen::Vector3d moved = Eigen::Vector3d::Zero();
  for (int k = 0; k < f.count; ++k) {
    const Index v = f.vertices[static_cast<std::size_t>(k)];
    moved += f.weights[k] * (vertex(x, v) - vertex(*substepStart_, v));
  }
  const Eigen::Vector3d other =
      f.obstacle >= 0 ? surfaceMotion(static_cast<std::size_t>(f.obstacle), f.point) : Eigen::Vector3d::Zero();
  stats.work -= g.dot(other);
  stats.dissipated += g.dot(moved - other);
}

ContactModel::FrictionShare ContactModel::frictionShare(const Friction& f, const VectorX& x,
                                                        bool wantHessian) const {
  // Lagged friction: mu lambda f0(|u|), u = T^T (sum_k w_k (x_k - xc_k) - offset).
  FrictionShare out;
  Eigen::Vector3d r = -f.offset;
  for (int k = 0; k < f.count; ++k) {
    const Index v = f.vertices[static_cast<std::size_t>(k)];
    r += f.weights[k] * (vertex(x, v) - vertex(frictionOrigin_, v));
  }
  const Eigen::Vector2d u = f.tangent.transpose() * r;
  const double y = u.norm();
  out.energy = f.muLambda * friction::f0(y, frictionEps_);
  out.gradient = f.muLambda * friction::f1OverY(y, frictionEps_) * (f.tangent * u);
  if (wantHessian) {
    // Positive semi-definite as it is (Li et al. 2020, section 5.2).
    const Eigen::Matrix2d H2 = f.muLambda * (friction::f1OverY(y, frictionEps_) * Eigen::Matrix2d::Identity() +
                                             friction::hessianRadialCoefficient(y, frictionEps_) * u * u.transpose());
    out.hessian = f.tangent * H2 * f.tangent.transpose();
  }
  return out;
}

void ContactModel::prepareVertexAccess() {
  if (vertexTablesFresh_) return;
  const Mesh& mesh = *mesh_;
  pairStencils_.clear();
  for (const auto& [p, t] : pointTriangle_) {
    const Triangle& tri = mesh.triangles[static_cast<std::size_t>(t)];
    pairStencils_.push_back({p, tri[0], tri[1], tri[2]});
  }
  for (const auto& [ia, ib] : edgeEdge_) {
    const auto& ea = edges_[static_cast<std::size_t>(ia)];
    const auto& eb = edges_[static_cast<std::size_t>(ib)];
    pairStencils_.push_back({ea[0], ea[1], eb[0], eb[1]});
  }
  pairsOfVertex_.assign(mesh.numVertices(), pairStencils_);
  frictionStencils_.clear();
  for (const Friction& f : friction_) {
    frictionStencils_.push_back({f.vertices.data(), f.vertices.data() + f.count});
  }
  frictionOfVertex_.assign(mesh.numVertices(), frictionStencils_);
  boxPairCloth_.resize(boxPairs_.size());
  boxPairStencils_.clear();
  for (std::size_t j = 0; j < boxPairs_.size(); ++j) {
    const int count = boxPairVertices(boxPairs_[j], boxPairCloth_[j]);
    boxPairStencils_.push_back({boxPairCloth_[j].data(), boxPairCloth_[j].data() + count});
  }
  boxPairsOfVertex_.assign(mesh.numVertices(), boxPairStencils_);
  vertexTablesFresh_ = true;
}

bool ContactModel::vertexDerivatives(const VectorX& x, Index v, VertexDerivatives& out,
                                     Part part) const {
  if (!vertexTablesFresh_) return false;
  VertexDerivatives sum;
  if (part != Part::Friction && !addVertexBarriers(x, v, sum)) return false;
  if (part != Part::Barriers) addVertexFriction(x, v, sum);
  out = sum;
  return true;
}

bool ContactModel::addVertexBarriers(const VectorX& x, Index v, VertexDerivatives& out) const {
  const double dHat = settings_.distance;
  for (std::size_t k = 0; k < obstacles_->size() && isFree(v); ++k) {
    const SignedDistance sd = obstacles_->distanceAt(k, vertex(x, v), true);
    if (!(sd.distance > 0.0)) return false;
    if (sd.distance >= dHat) continue;
    const VertexBarrier b = vertexBarrier(v, sd);
    out.force -= b.gradient;
    out.hessian += (b.weight * b.along) * (sd.normal * sd.normal.transpose());
  }
  for (std::size_t j = 0; !samples_.empty() && isFree(v) && j < samplesOfVertex_[static_cast<std::size_t>(v)].size(); ++j) {
    const auto [index, slot] = samplesOfVertex_[static_cast<std::size_t>(v)][j];
    const SurfaceSample& s = samples_[static_cast<std::size_t>(index)];
    const Eigen::Vector3d p = samplePoint(x, s);
    for (std::size_t k = 0; k < obstacles_->size(); ++k) {
      if (!round_[k] || roundLowerBound(k, p) >= dHat) continue;
      const SignedDistance sd = obstacles_->distanceAt(k, p, true);
      if (!(sd.distance > 0.0)) return false;
      if (sd.distance >= dHat) continue;
      const VertexBarrier b = massBarrier(kappa_ * s.mass, sd);
      const double w = s.weights[slot];
      out.force -= w * b.gradient;
      out.hessian += (w * w * b.weight * b.along) * (sd.normal * sd.normal.transpose());
    }
  }
  if (!boxPairs_.empty()) {
    PairBarrier b;
    double distance = 0.0;
    Eigen::Vector3d point;
    for (const VertexIncidence::Use& use : boxPairsOfVertex_.uses(v)) {
      const BoxPair& pair = boxPairs_[static_cast<std::size_t>(use.element)];
      if (!boxPairBarrier(x, pair, true, true, b, distance, point)) return false;
      if (!b.active) continue;
      const int slot = use.slot + (pair.edgeEdge ? 2 : 1);  // the box's point(s) come first
      out.force -= b.gradient.segment<3>(3 * slot);
      out.hessian += b.hessian.block<3, 3>(3 * slot, 3 * slot);
    }
  }
  if (settings_.selfCollision) {
    PairBarrier b;
    double distance = 0.0;
    const auto pointTriangles = static_cast<Index>(pointTriangle_.size());
    for (const VertexIncidence::Use& use : pairsOfVertex_.uses(v)) {
      const bool ok = use.element < pointTriangles
                          ? pointTriangleBarrier(x, pointTriangle_[use.element].first,
                                                 pointTriangle_[use.element].second, true, true, b,
                                                 distance)
                          : edgeEdgeBarrier(x, edgeEdge_[use.element - pointTriangles].first,
                                            edgeEdge_[use.element - pointTriangles].second, true,
                                            true, b, distance);
      if (!ok) return false;
      if (!b.active) continue;
      out.force -= b.gradient.segment<3>(3 * use.slot);
      out.hessian += b.hessian.block<3, 3>(3 * use.slot, 3 * use.slot);
    }
  }
  return true;
}

void ContactModel::addVertexFriction(const VectorX& x, Index v, VertexDerivatives& out) const {
  for (const VertexIncidence::Use& use : frictionOfVertex_.uses(v)) {
    const Friction& f = friction_[static_cast<std::size_t>(use.element)];
    const FrictionShare share = frictionShare(f, x, true);
    const double w = f.weights[use.slot];
    out.force -= w * share.gradient;
    out.hessian += (w * w) * share.hessian;
  }
}

void ContactModel::finishSubstep(const VectorX& x, const VectorX& x0, ContactStats& stats) {
  // The forces at the end of the substep are the ones the implicit step applied over it (its
  // equations of motion hold there): the obstacles' work is each one times the motion of the
  // obstacle's surface point under it, friction's loss each friction force times the slide
  // relative to the other side (evaluateAll with stats), the stored energy the barriers' there.
  std::vector<ObstacleWrench>& wrench = finishWrench_;  // kept: no allocation in a steady step
  wrench.assign(obstacles_->size(), ObstacleWrench{});
  ContactStats here;
  substepStart_ = &x0;
  evaluateAll(x, nullptr, nullptr, nullptr, 1.0, &wrench, &here);
  substepStart_ = nullptr;
  obstacles_->setWrenches(wrench);
  stats.contacts = here.contacts;
  stats.minDistance = here.minDistance;
  stats.work += here.work;
  stats.dissipated += here.dissipated;
  stats.stored = here.stored;
  if (stats.crossing.empty()) stats.crossing = surfaceCrossing(x);
  // The grid's depth is positive only where a triangle overlaps a box, which boxCrossing finds
  // exactly: measured only then (for the failing substep's report).
  const std::string intoBox = boxes_.empty() ? std::string() : boxCrossing(x);
  if (stats.crossing.empty()) stats.crossing = intoBox;
  if (!intoBox.empty()) measureBoxDepth(x, stats);
  pinned_ = nullptr;
}

double ContactModel::storedEnergy(const VectorX& x, const std::vector<char>& pinned) {
  pinned_ = &pinned;
  obstacles_->beginSubstep(0.0, 0.0);
  if (settings_.selfCollision) selfCandidates(x, nullptr);
  if (!boxes_.empty()) boxCandidates(x, nullptr);
  const double energy = evaluateAll(x, nullptr, nullptr, nullptr, 1.0, nullptr, nullptr, Part::Barriers);
  pinned_ = nullptr;
  return energy;
}

}  // namespace fem_cloth
