// The contact model's box features: each box corner against the cloth's triangles and each box
// edge against the cloth's edges (contact_model.h, box_features.h).
#include <algorithm>
#include <cmath>

#include "fem_cloth/core/contact/barrier.h"
#include "fem_cloth/core/contact/box_features.h"
#include "fem_cloth/core/contact/broad_phase.h"
#include "fem_cloth/core/contact/ccd.h"
#include "fem_cloth/core/contact/contact_model.h"

namespace fem_cloth {

namespace {

Eigen::Vector3d vertex(const VectorX& x, Index i) { return x.segment<3>(3 * i); }

}  // namespace

Eigen::Vector3d ContactModel::boxCorner(std::size_t k, int i, bool atEnd) const {
  return (atEnd ? obstacles_->poseEnd(k) : obstacles_->poseStart(k)) * box::corner((*obstacles_)[k].shape.halfExtents, i);
}

double ContactModel::boxPairWeight(const std::array<Index, 3>& cloth, int count) const {
  double mass = 0.0;
  for (int i = 0; i < count; ++i) mass += mass_[cloth[static_cast<std::size_t>(i)]];
  return kappa_ * mass / count;
}

int ContactModel::boxPairVertices(const BoxPair& pair, std::array<Index, 3>& cloth) const {
  if (pair.edgeEdge) {
    const auto& e = edges_[static_cast<std::size_t>(pair.cloth)];
    cloth = {e[0], e[1], e[1]};
    return 2;
  }
  const Triangle& t = mesh_->triangles[static_cast<std::size_t>(pair.cloth)];
  cloth = {t[0], t[1], t[2]};
  return 3;
}

int ContactModel::boxPairPoints(const VectorX& x, const BoxPair& pair, Eigen::Matrix<double, 3, 4>& X,
                                std::array<Index, 3>& cloth, bool atEnd) const {
  const auto k = static_cast<std::size_t>(pair.box);
  const int count = boxPairVertices(pair, cloth);
  if (pair.edgeEdge) {
    const std::array<int, 2> e = box::edge(pair.feature);
    X << boxCorner(k, e[0], atEnd), boxCorner(k, e[1], atEnd), vertex(x, cloth[0]), vertex(x, cloth[1]);
  } else {
    X << boxCorner(k, pair.feature, atEnd), vertex(x, cloth[0]), vertex(x, cloth[1]), vertex(x, cloth[2]);
  }
  return count;
}

bool ContactModel::boxPairBarrier(const VectorX& x, const BoxPair& pair, bool wantGradient, bool wantHessian,
                                  PairBarrier& out, double& distance, Eigen::Vector3d& point) const {
  Eigen::Matrix<double, 3, 4> X;
  std::array<Index, 3> cloth{};
  const int count = boxPairPoints(x, pair, X, cloth);
  PrimitiveDistance pd;
  const bool ok = pairBarrier(X, pair.edgeEdge, boxPairWeight(cloth, count), boxPairEpsX(pair, X), wantGradient,
                              wantHessian, out, distance, pd);
  // The box's closest point: the corner, or the point of its edge (the first primitive's
  // weights).
  point = pair.edgeEdge ? Eigen::Vector3d(pd.weights[0] * X.col(0) + pd.weights[1] * X.col(1)) : Eigen::Vector3d(X.col(0));
  return ok;
}

double ContactModel::boxPairEpsX(const BoxPair& pair, const Eigen::Matrix<double, 3, 4>& X) const {
  // As for two cloth edges (edgeMollifierThreshold), with the box edge's length.
  return pair.edgeEdge ? 1e-3 * (X.col(1) - X.col(0)).squaredNorm() * restEdgeSquared_[static_cast<std::size_t>(pair.cloth)]
                       : 0.0;
}

void ContactModel::boxCandidates(const VectorX& x, const VectorX* dx, bool atEnd) {
  const double dHat = settings_.distance;
  auto motionBox = [&](std::initializer_list<Index> vertices) {
    Aabb b;
    for (Index v : vertices) {
      b.extend(vertex(x, v));
      if (dx != nullptr) b.extend(vertex(x, v) + vertex(*dx, v));
    }
    b.inflate(0.5 * dHat);
    return b;
  };
  boxPairs_.clear();
  for (std::size_t k : boxes_) {
    std::array<Aabb, box::kEdges> edgeBoxes;
    Aabb whole;
    for (int j = 0; j < box::kEdges; ++j) {
      const std::array<int, 2> e = box::edge(j);
      edgeBoxes[static_cast<std::size_t>(j)].extend(boxCorner(k, e[0], atEnd));
      edgeBoxes[static_cast<std::size_t>(j)].extend(boxCorner(k, e[1], atEnd));
      edgeBoxes[static_cast<std::size_t>(j)].inflate(0.5 * dHat);
      whole.extend(edgeBoxes[static_cast<std::size_t>(j)].lo);
      whole.extend(edgeBoxes[static_cast<std::size_t>(j)].hi);
    }
    const int box = static_cast<int>(k);
    for (Index t = 0; t < mesh_->numTriangles(); ++t) {
      const Triangle& tri = mesh_->triangles[static_cast<std::size_t>(t)];
      if (!freeTriangle(tri)) continue;  // the pin wins
      const Aabb b = motionBox({tri[0], tri[1], tri[2]});
      if (!b.overlaps(whole)) continue;
      for (int i = 0; i < box::kCorners; ++i) {
        Aabb c;
        c.extend(boxCorner(k, i, atEnd));
        c.inflate(0.5 * dHat);
        if (b.overlaps(c)) boxPairs_.push_back({box, i, static_cast<int>(t), false});
      }
    }
    for (std::size_t e = 0; e < edges_.size(); ++e) {
      if (!(isFree(edges_[e][0]) && isFree(edges_[e][1]))) continue;
      const Aabb b = motionBox({edges_[e][0], edges_[e][1]});
      if (!b.overlaps(whole)) continue;
      for (int j = 0; j < box::kEdges; ++j) {
        if (b.overlaps(edgeBoxes[static_cast<std::size_t>(j)])) boxPairs_.push_back({box, j, static_cast<int>(e), true});
      }
    }
  }
  vertexTablesFresh_ = false;
}

double ContactModel::boxSegment(const VectorX& x, const VectorX& dx, double tMax, VectorX* perDof) {
  const bool moving = dx.size() == x.size() && !dx.isZero();
  boxCandidates(x, moving ? &dx : nullptr);
  if (!moving) return tMax;
  double t = tMax;
  Eigen::Matrix<double, 3, 4> X, D;
  std::array<Index, 3> cloth{};
  for (const BoxPair& pair : boxPairs_) {
    const int count = boxPairPoints(x, pair, X, cloth);
    D.setZero();  // the box stays where it ends the substep
    for (int i = 0; i < count; ++i) D.col(4 - count + i) = vertex(dx, cloth[static_cast<std::size_t>(i)]);
    ++checks_;
    const double cap = perDof != nullptr ? 1.0 : t;
    const double tp = pair.edgeEdge ? ccd::edgeEdge(X, D, cap) : ccd::pointTriangle(X, D, cap);
    if (perDof != nullptr) {
      for (int i = 0; i < count; ++i) {
        const Index v = cloth[static_cast<std::size_t>(i)];
        perDof->segment<3>(3 * v) = perDof->segment<3>(3 * v).cwiseMin(tp);
      }
    }
    t = std::min(t, tp);
  }
  return t;
}

bool ContactModel::addBoxPairBarriers(const VectorX& x, Assembly& a) {
  const bool wantHessian = a.hessian != nullptr;
  const bool wantGradient = a.wantsGradient();
  PairBarrier b;
  double distance = 0.0;
  Eigen::Vector3d point;
  std::array<Index, 3> cloth{};
  for (const BoxPair& pair : boxPairs_) {
    ++checks_;
    const bool ok = boxPairBarrier(x, pair, wantGradient, wantHessian, b, distance, point);
    a.note(distance, settings_.distance);
    if (!ok) return false;
    if (!b.active) continue;
    a.energy += b.energy;
    if (!wantGradient) continue;
    const int count = boxPairVertices(pair, cloth);
    const int first = 4 - count;  // the cloth's slots in the pair
    Eigen::Vector3d g = Eigen::Vector3d::Zero();  // dE/dx summed over the cloth's side
    for (int i = 0; i < count; ++i) {
      const Index v = cloth[static_cast<std::size_t>(i)];
      g += b.gradient.segment<3>(3 * (first + i));
      if (a.gradient != nullptr) a.gradient->segment<3>(3 * v) += a.scale * b.gradient.segment<3>(3 * (first + i));
      for (int j = 0; wantHessian && j < count; ++j) {
        addBlock(v, cloth[static_cast<std::size_t>(j)],
                 a.scale * b.hessian.block<3, 3>(3 * (first + i), 3 * (first + j)), a.hessian, a.outside);
      }
    }
    const auto k = static_cast<std::size_t>(pair.box);
    if (a.wrench != nullptr) {
      (*a.wrench)[k].force += g;  // the cloth pushes the box with +dE/dx
      (*a.wrench)[k].torque += point.cross(g);
    }
    if (a.stats != nullptr) a.stats->work -= g.dot(surfaceMotion(k, point));
  }
  return true;
}

void ContactModel::markTrianglesBoxesReach(const VectorX& x0) {
  const double dHat = settings_.distance;
  const std::size_t obstacleCount = obstacles_->size();
  for (std::size_t k : boxes_) {
    const Eigen::Isometry3d &start = obstacles_->poseStart(k), &end = obstacles_->poseEnd(k);
    if (start.matrix() == end.matrix()) continue;
    const Eigen::Vector3d& h = (*obstacles_)[k].shape.halfExtents;
    // In the box's frame a point p moves at most |shift| + angle |p - centre| (+ |shift|).
    const Eigen::Vector3d shift = end.translation() - start.translation();
    const double angle = Eigen::AngleAxisd(start.linear().transpose() * end.linear()).angle();
    for (Index t = 0; t < mesh_->numTriangles(); ++t) {
      const Triangle& tri = mesh_->triangles[static_cast<std::size_t>(t)];
      if (!freeTriangle(tri)) continue;
      const std::array<Eigen::Vector3d, 3> p{vertex(x0, tri[0]), vertex(x0, tri[1]), vertex(x0, tri[2])};
      double reach = 0.0;  // the farthest vertex from the box's centre
      for (const Eigen::Vector3d& q : p) reach = std::max(reach, (q - start.translation()).norm());
      const double lp = shift.norm() + angle * (reach + shift.norm());
      // The triangle is within `side` of its first vertex: far from the box's bounding sphere
      // over the whole motion, it cannot come near.
      const double side = std::max((p[1] - p[0]).norm(), (p[2] - p[0]).norm());
      if ((p[0] - start.translation()).norm() - side - h.norm() - lp > dHat) continue;
      auto distanceAt = [&](double s) {
        const Eigen::Isometry3d inverse = interpolatePose(start, end, s).inverse();
        return box::triangleDistance(h, inverse * p[0], inverse * p[1], inverse * p[2]);
      };
      if (!ccd::comesWithin(distanceAt, distanceAt(0.0), lp, dHat)) continue;
      for (Index v : tri) reached_[static_cast<std::size_t>(v) * obstacleCount + k] = 2;
    }
  }
}

std::string ContactModel::boxCrossing(const VectorX& x) const {
  for (std::size_t k : boxes_) {
    std::string crossing = boxCrossing(x, k);
    if (crossing.empty()) continue;
    char text[64];
    std::snprintf(text, sizeof text, " (moving at %.3g m/s)", obstacleSpeed(k));
    return crossing + text;
  }
  return {};
}

std::string ContactModel::boxCrossing(const VectorX& x, std::size_t k) const {
  const Eigen::Isometry3d& inverse = obstacles_->inverseEnd(k);
  const Eigen::Vector3d& h = (*obstacles_)[k].shape.halfExtents;
  for (Index t = 0; t < mesh_->numTriangles(); ++t) {
    const Triangle& tri = mesh_->triangles[static_cast<std::size_t>(t)];
    if (!freeTriangle(tri)) continue;  // the pin wins
    const Eigen::Vector3d a = inverse * vertex(x, tri[0]), b = inverse * vertex(x, tri[1]), c = inverse * vertex(x, tri[2]);
    if (box::beyondOneFace(h, a, b, c) || !box::overlapsTriangle(h, a, b, c)) continue;
    return "triangle " + std::to_string(t) + " (vertices " + std::to_string(tri[0]) + ", " + std::to_string(tri[1]) +
           ", " + std::to_string(tri[2]) + ") reaches into box '" + (*obstacles_)[k].name + "'";
  }
  return {};
}

}  // namespace fem_cloth
