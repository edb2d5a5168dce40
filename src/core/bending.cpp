#include "fem_cloth/core/bending.h"

#include "fem_cloth/core/bending_midedge.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <tuple>

namespace fem_cloth {

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

/// d(.)/dx of a 3-vector function of the 12 hinge coordinates.
using HingeJacobian = Eigen::Matrix<double, 3, 12>;
using HingeRow = Eigen::Matrix<double, 1, 12>;

constexpr double kTwoPi = 2.0 * 3.14159265358979323846;

Matrix3d crossMatrix(const Vector3d& v) {
  Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

/// d(xb - xa)/dx for hinge vertices a, b.
HingeJacobian differenceJacobian(int a, int b) {
  HingeJacobian J = HingeJacobian::Zero();
  J.block<3, 3>(0, 3 * a) = -Matrix3d::Identity();
  J.block<3, 3>(0, 3 * b) = Matrix3d::Identity();
  return J;
}

/// The gradient of theta on an opposite vertex is g = -|e| n / |n|^2 (n the normal of its
/// triangle, |n| / |e| its height over the edge): moving the vertex along n by delta turns its
/// triangle by delta / height about the edge. Returns dg/dx given dn/dx and d|e|/dx.
HingeJacobian oppositeGradientJacobian(const Vector3d& n, double normalSq, double edgeLength,
                                       const HingeJacobian& dn, const HingeRow& dEdgeLength) {
  // d(n / |n|^2) = (I - 2 n n^T / |n|^2) dn / |n|^2.
  const Matrix3d reflect = Matrix3d::Identity() - (2.0 / normalSq) * n * n.transpose();
  return -(n / normalSq) * dEdgeLength - (edgeLength / normalSq) * reflect * dn;
}

/// d t / dx for t = (b . e) / |e|^2, the position of an opposite vertex's foot along the edge.
HingeRow footJacobian(const Vector3d& e, const Vector3d& b, double t, double edgeLengthSq,
                      const HingeJacobian& de, const HingeJacobian& db) {
  return (e.transpose() * db + b.transpose() * de - 2.0 * t * e.transpose() * de) / edgeLengthSq;
}

double cotangentAt(const Vector3d& apex, const Vector3d& p, const Vector3d& q) {
  const Vector3d u = p - apex, v = q - apex;
  return u.dot(v) / u.cross(v).norm();
}

/// A1 + A2: the rest areas of the hinge's two triangles (m^2).
double restAreaSum(const RestState& rest, const Hinge& hinge) {
  return rest.restArea[hinge.triangles[0]] + rest.restArea[hinge.triangles[1]];
}

}  // namespace

std::vector<Hinge> buildHinges(const Mesh& mesh) {
  struct HalfEdge {
    std::array<Index, 2> edge;  // i < j
    Index triangle;
    int corner;  // local index of the edge's first vertex in the triangle
    bool operator<(const HalfEdge& o) const {
      return std::tie(edge, triangle) < std::tie(o.edge, o.triangle);
    }
  };
  std::vector<HalfEdge> halfEdges;
  halfEdges.reserve(mesh.triangles.size() * 3);
  for (Index t = 0; t < mesh.numTriangles(); ++t) {
    const Triangle& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k) {
      const Index a = tri[k], b = tri[(k + 1) % 3];
      halfEdges.push_back({{std::min(a, b), std::max(a, b)}, t, k});
    }
  }
  std::sort(halfEdges.begin(), halfEdges.end());
  std::vector<Hinge> hinges;
  for (std::size_t first = 0; first < halfEdges.size();) {
    std::size_t last = first + 1;
    while (last < halfEdges.size() && halfEdges[last].edge == halfEdges[first].edge) ++last;
    if (last - first == 2) {
      const HalfEdge& a = halfEdges[first];
      const HalfEdge& b = halfEdges[first + 1];
      const Triangle& A = mesh.triangles[a.triangle];
      const Triangle& B = mesh.triangles[b.triangle];
      Hinge hinge;
      hinge.vertices = {A[a.corner], A[(a.corner + 1) % 3], A[(a.corner + 2) % 3],
                        B[(b.corner + 2) % 3]};
      hinge.triangles = {a.triangle, b.triangle};
      if (hinge.vertices[2] != hinge.vertices[3]) hinges.push_back(hinge);
    }
    first = last;
  }
  return hinges;
}

double bendingStiffness(double youngsModulus, double thickness, double poissonRatio) {
  return youngsModulus * thickness * thickness * thickness /
         (12.0 * (1.0 - poissonRatio * poissonRatio));
}

HingePositions hingePositions(const VectorX& x, const Hinge& hinge) {
  HingePositions X;
  for (int a = 0; a < 4; ++a) X.col(a) = x.segment<3>(3 * hinge.vertices[a]);
  return X;
}

HingeMatrix clampNegativeEigenvalues(const HingeMatrix& H) {
  const Eigen::SelfAdjointEigenSolver<HingeMatrix> solver(H);
  const HingeVector clamped = solver.eigenvalues().cwiseMax(0.0);
  const HingeMatrix P =
      solver.eigenvectors() * clamped.asDiagonal() * solver.eigenvectors().transpose();
  // V D V^T is symmetric only up to round-off; the assembled matrix should be exactly symmetric.
  return 0.5 * (P + P.transpose());
}

bool dihedralAngle(const HingePositions& x, double* angle, HingeVector* gradient,
                   HingeMatrix* hessian) {
  const Vector3d e = x.col(1) - x.col(0);
  const Vector3d b2 = x.col(2) - x.col(0);
  const Vector3d b3 = x.col(3) - x.col(0);
  const Vector3d n1 = e.cross(b2);
  const Vector3d n2 = b3.cross(e);
  const double edgeLengthSq = e.squaredNorm();
  const double n1Sq = n1.squaredNorm();
  const double n2Sq = n2.squaredNorm();
  // Negated comparisons also reject NaN.
  if (!(edgeLengthSq > 0.0) || !(n1Sq > 0.0) || !(n2Sq > 0.0)) return false;
  const double edgeLength = std::sqrt(edgeLengthSq);
  *angle = std::atan2(n1.cross(n2).dot(e) / edgeLength, n1.dot(n2));
  if (gradient == nullptr && hessian == nullptr) return true;

  // Gradient (as in Bridson, Marino, Fedkiw, "Simulation of clothing with folds and wrinkles",
  // SCA 2003, and Tamstorf & Grinspun, "Discrete bending forces and their Jacobians", 2013;
  // written in this hinge's notation): on the opposite vertices -|e| n / |n|^2; on the edge
  // vertices the combination fixed by invariance under translation and rotation, weighted by
  // where the opposite vertices' feet t2, t3 lie along the edge (t = 0 at x0, 1 at x1).
  const Vector3d g2 = -(edgeLength / n1Sq) * n1;
  const Vector3d g3 = -(edgeLength / n2Sq) * n2;
  const double t2 = b2.dot(e) / edgeLengthSq;
  const double t3 = b3.dot(e) / edgeLengthSq;
  const Vector3d g0 = -(1.0 - t2) * g2 - (1.0 - t3) * g3;
  const Vector3d g1 = -t2 * g2 - t3 * g3;
  if (gradient != nullptr) *gradient << g0, g1, g2, g3;
  if (hessian == nullptr) return true;

  // Hessian: the derivative of the gradient above, by the chain rule through the bilinear
  // normals n1 = e x b2, n2 = b3 x e, the edge length and the feet t2, t3.
  const HingeJacobian de = differenceJacobian(0, 1);
  const HingeJacobian db2 = differenceJacobian(0, 2);
  const HingeJacobian db3 = differenceJacobian(0, 3);
  const HingeJacobian dn1 = crossMatrix(e) * db2 - crossMatrix(b2) * de;
  const HingeJacobian dn2 = crossMatrix(b3) * de - crossMatrix(e) * db3;
  const HingeRow dEdgeLength = (e / edgeLength).transpose() * de;
  const HingeJacobian dg2 = oppositeGradientJacobian(n1, n1Sq, edgeLength, dn1, dEdgeLength);
  const HingeJacobian dg3 = oppositeGradientJacobian(n2, n2Sq, edgeLength, dn2, dEdgeLength);
  const HingeRow dt2 = footJacobian(e, b2, t2, edgeLengthSq, de, db2);
  const HingeRow dt3 = footJacobian(e, b3, t3, edgeLengthSq, de, db3);
  HingeMatrix H;
  H.middleRows<3>(0) = g2 * dt2 - (1.0 - t2) * dg2 + g3 * dt3 - (1.0 - t3) * dg3;
  H.middleRows<3>(3) = -g2 * dt2 - t2 * dg2 - g3 * dt3 - t3 * dg3;
  H.middleRows<3>(6) = dg2;
  H.middleRows<3>(9) = dg3;
  // Symmetric in exact arithmetic; symmetrising removes the round-off difference.
  *hessian = 0.5 * (H + H.transpose());
  return true;
}

// ---------------------------------------------------------------------------------------------
// HingeTerm
// ---------------------------------------------------------------------------------------------

HingeTerm::HingeTerm(const Mesh& mesh, double stiffness)
    : stiffness_(stiffness), numVertices_(mesh.numVertices()), hinges_(buildHinges(mesh)) {
  const std::size_t m = hinges_.size();
  energy_.assign(m, 0.0);
  inDomain_.assign(m, 1);
  gradient_.assign(m, HingeVector::Zero());
}

void HingeTerm::prepareVertexAccess() {
  // The derived term's stencils: the hinges, or the mid-edge model's elements.
  if (!incidence_.isBuilt()) incidence_ = stencilIncidence(*this, numVertices_);
}

void HingeTerm::appendStencils(std::vector<std::vector<Index>>* stencils) const {
  for (const Hinge& h : hinges_) {
    stencils->push_back({h.vertices[0], h.vertices[1], h.vertices[2], h.vertices[3]});
  }
}

void HingeTerm::bindHessian(const SparseHessian& hessian) {
  offsets_.resize(hinges_.size() * kOffsetsPerHinge);
  std::vector<int> local;
  for (std::size_t h = 0; h < hinges_.size(); ++h) {
    const auto& v = hinges_[h].vertices;
    hessian.stencilOffsets({v[0], v[1], v[2], v[3]}, local);
    std::copy(local.begin(), local.end(), offsets_.begin() + static_cast<long>(h * kOffsetsPerHinge));
  }
}

HingePositions HingeTerm::gather(const VectorX& x, std::size_t hinge) const {
  return hingePositions(x, hinges_[hinge]);
}

EvalResult HingeTerm::reduce(const EvalRequest& request) const {
  EvalResult result;
  for (std::size_t h = 0; h < hinges_.size(); ++h) {
    if (!inDomain_[h]) {
      if (result.inDomain) result.firstBadElement = static_cast<Index>(h);
      result.inDomain = false;
      continue;
    }
    if (request.energy) result.energy += energy_[h];
    if (request.gradient != nullptr) {
      for (int a = 0; a < 4; ++a) {
        request.gradient->segment<3>(3 * hinges_[h].vertices[a]) += gradient_[h].segment<3>(3 * a);
      }
    }
  }
  if (!result.inDomain) result.energy = kInfiniteEnergy;
  return result;
}

// ---------------------------------------------------------------------------------------------
// QuadraticBending
// ---------------------------------------------------------------------------------------------

QuadraticBending::QuadraticBending(const Mesh& mesh, const RestState& rest, double stiffness)
    : HingeConstraintTerm(mesh, stiffness) {
  stencils_.reserve(hinges_.size());
  weights_.reserve(hinges_.size());
  for (const Hinge& hinge : hinges_) {
    const HingePositions X = hingePositions(mesh.restPositions, hinge);
    // Bergou et al. 2006: the vector K0 of the paper.
    const double c01 = cotangentAt(X.col(0), X.col(1), X.col(2));
    const double c02 = cotangentAt(X.col(0), X.col(1), X.col(3));
    const double c03 = cotangentAt(X.col(1), X.col(0), X.col(2));
    const double c04 = cotangentAt(X.col(1), X.col(0), X.col(3));
    stencils_.emplace_back(c03 + c04, c01 + c02, -c01 - c03, -c02 - c04);
    weights_.push_back(stiffness / restAreaSum(rest, hinge));
  }
}

EvalResult QuadraticBending::evaluate(const VectorX& x, const EvalRequest& request) {
  const Index m = static_cast<Index>(hinges_.size());
  const bool wantGradient = request.gradient != nullptr;
#pragma omp parallel for schedule(static) if (m >= kParallelElementThreshold)
  for (Index h = 0; h < m; ++h) {
    const Vector3d curvatureNormal = gather(x, h) * stencils_[h];
    energy_[h] = 0.5 * weights_[h] * curvatureNormal.squaredNorm();
    if (wantGradient) {
      for (int a = 0; a < 4; ++a) {
        gradient_[h].segment<3>(3 * a) = (weights_[h] * stencils_[h][a]) * curvatureNormal;
      }
    }
  }
  const EvalResult result = reduce(request);
  if (request.hessian != nullptr) {
    // Block (a, b) is w K_a K_b I_3, the same for every x and already PSD (a Gram matrix), so
    // both Hessian modes add it as it is, straight from K: only the diagonal of each block.
    double* values = request.hessian->values();
    for (Index h = 0; h < m; ++h) {
      const int* off = offsets(h);
      for (int a = 0; a < 4; ++a) {
        for (int b = 0; b < 4; ++b) {
          // K_a K_b first: bitwise the same for (a, b) and (b, a), so Q is exactly symmetric.
          const double entry = weights_[h] * (stencils_[h][a] * stencils_[h][b]);
          for (int k = 0; k < 3; ++k) values[off[(a * 4 + b) * 3 + k] + k] += entry;
        }
      }
    }
  }
  return result;
}

bool QuadraticBending::vertexDerivatives(const VectorX& x, Index vertex, HessianMode /*mode*/,
                                         VertexDerivatives& out) const {
  if (!incidence_.isBuilt()) return false;  // not prepared
  out = VertexDerivatives{};
  for (const VertexIncidence::Use& use : incidence_.uses(vertex)) {
    const auto h = static_cast<std::size_t>(use.element);
    const double Ka = stencils_[h][use.slot];
    out.force -= (weights_[h] * Ka) * (gather(x, h) * stencils_[h]);
    out.hessian.diagonal().array() += weights_[h] * (Ka * Ka);
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// DihedralBending
// ---------------------------------------------------------------------------------------------

void QuadraticBending::appendProjectiveMatrix(std::vector<Eigen::Triplet<double>>* triplets) const {
  for (std::size_t h = 0; h < hinges_.size(); ++h) {
    for (int a = 0; a < 4; ++a) {
      for (int b = 0; b < 4; ++b) {
        triplets->emplace_back(hinges_[h].vertices[a], hinges_[h].vertices[b],
                               weights_[h] * stencils_[h][a] * stencils_[h][b]);
      }
    }
  }
}

bool QuadraticBending::elementConstraints(Index h, const VectorX& x, double* C,
                                          double* jacobian) const {
  const std::size_t hinge = static_cast<std::size_t>(h);
  const Vector3d curvatureNormal = gather(x, hinge) * stencils_[hinge];
  Eigen::Map<Eigen::Matrix<double, 3, 12, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  for (int k = 0; k < 3; ++k) {
    C[k] = curvatureNormal[k];
    for (int a = 0; a < 4; ++a) J(k, 3 * a + k) = stencils_[hinge][a];
  }
  return true;
}

void QuadraticBending::elementConstraintStiffness(Index h, double* K) const {
  Eigen::Map<Eigen::Matrix3d> stiffness(K);
  stiffness = weights_[static_cast<std::size_t>(h)] * Eigen::Matrix3d::Identity();
}

DihedralBending::DihedralBending(const Mesh& mesh, const RestState& rest, double stiffness)
    : HingeConstraintTerm(mesh, stiffness) {
  restAngles_.reserve(hinges_.size());
  weights_.reserve(hinges_.size());
  for (const Hinge& hinge : hinges_) {
    const HingePositions X = hingePositions(mesh.restPositions, hinge);
    double restAngle = 0.0;
    // Rest triangles have positive area (computeRestState), so the angle is defined.
    dihedralAngle(X, &restAngle);
    restAngles_.push_back(restAngle);
    const double restEdgeSq = (X.col(1) - X.col(0)).squaredNorm();
    weights_.push_back(stiffness * restEdgeSq / (2.0 * restAreaSum(rest, hinge)));
  }
}

void DihedralBending::bindHessian(const SparseHessian& hessian) {
  HingeTerm::bindHessian(hessian);
  hessian_.resize(hinges_.size());
}

EvalResult DihedralBending::evaluate(const VectorX& x, const EvalRequest& request) {
  const Index m = static_cast<Index>(hinges_.size());
  const bool wantGradient = request.gradient != nullptr;
  const bool wantHessian = request.hessian != nullptr;
  const bool project = request.hessianMode == HessianMode::Projected;
#pragma omp parallel for schedule(static) if (m >= kParallelElementThreshold)
  for (Index h = 0; h < m; ++h) {
    double theta = 0.0;
    HingeVector dtheta;
    HingeMatrix d2theta;
    inDomain_[h] = dihedralAngle(gather(x, h), &theta,
                                 (wantGradient || wantHessian) ? &dtheta : nullptr,
                                 wantHessian ? &d2theta : nullptr);
    if (!inDomain_[h]) continue;
    const double delta = std::remainder(theta - restAngles_[h], kTwoPi);
    const double w = weights_[h];
    energy_[h] = w * delta * delta;
    if (wantGradient) gradient_[h] = (2.0 * w * delta) * dtheta;
    if (wantHessian) {
      hessian_[h] = (2.0 * w) * (dtheta * dtheta.transpose() + delta * d2theta);
      if (project) hessian_[h] = clampNegativeEigenvalues(hessian_[h]);
    }
  }
  const EvalResult result = reduce(request);
  if (wantHessian) {
    for (Index h = 0; h < m; ++h) {
      if (inDomain_[h]) request.hessian->addElement<12>(hessian_[h], offsets(h));
    }
  }
  return result;
}

bool DihedralBending::vertexDerivatives(const VectorX& x, Index vertex, HessianMode mode,
                                        VertexDerivatives& out) const {
  if (!incidence_.isBuilt()) return false;  // not prepared
  out = VertexDerivatives{};
  for (const VertexIncidence::Use& use : incidence_.uses(vertex)) {
    const auto h = static_cast<std::size_t>(use.element);
    double theta = 0.0;
    HingeVector dtheta;
    HingeMatrix d2theta;
    if (!dihedralAngle(gather(x, h), &theta, &dtheta, &d2theta)) return false;
    const double delta = std::remainder(theta - restAngles_[h], kTwoPi);
    const double w = weights_[h];
    const int a = 3 * use.slot;
    out.force -= (2.0 * w * delta) * dtheta.segment<3>(a);
    if (mode == HessianMode::Projected) {
      const HingeMatrix H = (2.0 * w) * (dtheta * dtheta.transpose() + delta * d2theta);
      out.hessian += clampNegativeEigenvalues(H).block<3, 3>(a, a);
    } else {
      out.hessian += (2.0 * w) * (dtheta.segment<3>(a) * dtheta.segment<3>(a).transpose() +
                                  delta * d2theta.block<3, 3>(a, a));
    }
  }
  return true;
}

bool DihedralBending::elementConstraints(Index h, const VectorX& x, double* C,
                                         double* jacobian) const {
  double theta = 0.0;
  HingeVector dtheta;
  if (!dihedralAngle(gather(x, static_cast<std::size_t>(h)), &theta, &dtheta)) return false;
  C[0] = std::remainder(theta - restAngles_[static_cast<std::size_t>(h)], kTwoPi);
  Eigen::Map<HingeVector> gradient(jacobian);
  gradient = dtheta;
  return true;
}

void DihedralBending::elementConstraintStiffness(Index h, double* K) const {
  K[0] = 2.0 * weights_[static_cast<std::size_t>(h)];
}

// ---------------------------------------------------------------------------------------------
// Factory
// ---------------------------------------------------------------------------------------------

Expected<std::unique_ptr<EnergyTerm>> makeBendingTerm(const Mesh& mesh, const RestState& rest,
                                                      const BendingSpec& spec) {
  if (!std::isfinite(spec.stiffness) || spec.stiffness < 0.0) {
    return Error{"bending stiffness must be finite and >= 0 (N m), got " + numberText(spec.stiffness)};
  }
  if (!(spec.poissonRatio >= 0.0 && spec.poissonRatio < 0.5)) {
    return Error{"bending Poisson ratio must be in [0, 0.5), got " + numberText(spec.poissonRatio)};
  }
  if (mesh.dim != 3) {
    return Error{"bending needs a cloth (3D) mesh; got a planar mesh (dim " +
                 std::to_string(mesh.dim) + ")"};
  }
  if (rest.dim != mesh.dim || rest.numTriangles() != mesh.numTriangles()) {
    return Error{"bending: the rest state (" + std::to_string(rest.numTriangles()) +
                 " triangles) does not belong to the mesh (" +
                 std::to_string(mesh.numTriangles()) + " triangles)"};
  }
  if (!spec.held.empty() && static_cast<Index>(spec.held.size()) != mesh.numVertices()) {
    return Error{"bending: the held-vertex list has " + std::to_string(spec.held.size()) +
                 " entries for " + std::to_string(mesh.numVertices()) + " vertices"};
  }
  if (spec.stiffness == 0.0) return std::unique_ptr<EnergyTerm>();
  if (spec.model == BendingModel::Midedge) {
    MidedgeOptions options;
    options.poissonRatio = spec.poissonRatio;
    options.held = spec.held;
    return std::unique_ptr<EnergyTerm>(
        std::make_unique<MidedgeBending>(mesh, rest, spec.stiffness, options));
  }
  if (spec.model == BendingModel::Quadratic) {
    return std::unique_ptr<EnergyTerm>(
        std::make_unique<QuadraticBending>(mesh, rest, spec.stiffness));
  }
  return std::unique_ptr<EnergyTerm>(std::make_unique<DihedralBending>(mesh, rest, spec.stiffness));
}

Expected<std::unique_ptr<EnergyTerm>> makeBendingTerm(const Mesh& mesh, const RestState& rest,
                                                      const std::string& model, double stiffness) {
  const std::optional<BendingModel> known = bendingModelFromName(model);
  if (!known) return Error{"unknown bending model '" + model + "' (known: " + commaList(bendingModelNames()) + ")"};
  BendingSpec spec;
  spec.model = *known;
  spec.stiffness = stiffness;
  return makeBendingTerm(mesh, rest, spec);
}

}  // namespace fem_cloth
