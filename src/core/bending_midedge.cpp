#include "fem_cloth/core/bending_midedge.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace fem_cloth {

namespace {

using Eigen::Matrix2d;
using Eigen::Matrix3d;
using Eigen::Vector2d;
using Eigen::Vector3d;

constexpr int kMaxHinges = MidedgeElement::kMaxHinges;
constexpr int kElementVertices = MidedgeElement::kMaxVertices;

/// A symmetric 2 x 2 tensor as (S11, S22, S12): the curvature h of a quadratic height field
/// w = S11 x^2 / 2 + S22 y^2 / 2 + S12 x y.
using Voigt = Eigen::Vector3d;
/// Linear functions of the bending measures of an element's stencil hinges (one column each).
using OnHinges = Eigen::Matrix<double, 1, kMaxHinges>;
using TensorOnHinges = Eigen::Matrix<double, 3, kMaxHinges>;

/// Values of the three quadratic monomials x^2/2, y^2/2, x y at p (their curvatures are the unit
/// Voigt vectors).
Voigt monomials(const Vector2d& p) { return Voigt(0.5 * p.x() * p.x(), 0.5 * p.y() * p.y(), p.x() * p.y()); }

Voigt outerVoigt(const Vector2d& n) { return Voigt(n.x() * n.x(), n.y() * n.y(), n.x() * n.y()); }

/// The plate's energy density in Voigt form, psi = 1/2 h^T C h (J / m^2 per unit D).
Matrix3d plateMatrix(double stiffness, double poissonRatio) {
  Matrix3d C;
  C << 1.0, poissonRatio, 0.0,  //
      poissonRatio, 1.0, 0.0,    //
      0.0, 0.0, 2.0 * (1.0 - poissonRatio);
  return stiffness * C;
}

/// The point at distances dA, dB from the chart points A, B, on the other side of line AB than
/// `away` (unfolding a neighbour triangle across the edge AB into the chart).
Vector2d unfold(const Vector2d& A, const Vector2d& B, double dA, double dB, const Vector2d& away) {
  const Vector2d e = B - A;
  const double l = e.norm();
  const Vector2d t = e / l;
  const Vector2d n(-t.y(), t.x());
  const double along = (dA * dA - dB * dB + l * l) / (2.0 * l);
  const double across = std::sqrt(std::max(dA * dA - along * along, 0.0));
  const double side = n.dot(away - A) > 0.0 ? -1.0 : 1.0;
  return A + along * t + side * across * n;
}

/// A triangle of the element's neighbourhood placed in the element's flat chart.
struct ChartTriangle {
  Index triangle = -1;
  std::array<Index, 3> vertices{};
  std::array<Vector2d, 3> points;
  Vector2d pointOf(Index v) const {
    for (int a = 0; a < 3; ++a) {
      if (vertices[a] == v) return points[a];
    }
    return Vector2d::Zero();  // not reached: callers ask for the triangle's own vertices
  }
  /// Face gradient of the linear interpolant: coefficients on the three vertices (2 x 3).
  Eigen::Matrix<double, 2, 3> gradientWeights() const {
    Matrix2d E;
    E.col(0) = points[1] - points[0];
    E.col(1) = points[2] - points[0];
    Eigen::Matrix<double, 2, 3> D;
    D << -1.0, 1.0, 0.0, -1.0, 0.0, 1.0;
    return E.transpose().inverse() * D;
  }
};

/// A hinge placed in the chart: its vertices (hinge order) at their unfolded positions, and its
/// linearised bending angle theta(w) = sum_a weight_a w_a for out-of-plane displacements w.
struct ChartHinge {
  Index hinge = -1;
  std::array<Index, 4> vertices{};
  std::array<Vector2d, 4> points;
  Eigen::Vector4d weights = Eigen::Vector4d::Zero();
  /// theta of the quadratic height field with curvature h: theta = curvature . h.
  Voigt curvature = Voigt::Zero();
};

ChartHinge placeHinge(const Hinge& hinge, Index index, const ChartTriangle& a, const ChartTriangle& b) {
  ChartHinge c;
  c.hinge = index;
  c.vertices = hinge.vertices;
  HingePositions flat = HingePositions::Zero();
  Vector2d centre = Vector2d::Zero();
  for (int k = 0; k < 4; ++k) {
    const Index v = hinge.vertices[k];
    const bool inA = std::find(a.vertices.begin(), a.vertices.end(), v) != a.vertices.end();
    c.points[k] = inA ? a.pointOf(v) : b.pointOf(v);
    centre += 0.25 * c.points[k];
  }
  for (int k = 0; k < 4; ++k) flat.col(k).head<2>() = c.points[k];
  // The gradient of the angle at the unfolded (flat) hinge, restricted to normal displacements,
  // is the linearisation; the same function as the dynamic angle, so the signs agree.
  double theta = 0.0;
  HingeVector gradient = HingeVector::Zero();
  dihedralAngle(flat, &theta, &gradient);  // rest triangles have area: the angle is defined
  for (int k = 0; k < 4; ++k) {
    c.weights[k] = gradient[3 * k + 2];
    c.curvature += c.weights[k] * monomials(c.points[k] - centre);
  }
  return c;
}

/// Everything an element's rest computation needs about its neighbourhood.
struct Neighbourhood {
  ChartTriangle self;
  std::array<int, 3> edgeHinge{{-1, -1, -1}};   // hinge of edge k (opposite vertex k), or -1
  std::array<ChartTriangle, 3> across;          // the triangle across edge k, when there is one
  std::vector<ChartHinge> hinges;               // stencil hinges, the element's own first
  std::array<std::vector<int>, 4> hingesOf;     // slots of the hinges of self (0), across[k] (k+1)
  int slotOf(Index hinge) const {
    for (std::size_t s = 0; s < hinges.size(); ++s) {
      if (hinges[s].hinge == hinge) return static_cast<int>(s);
    }
    return -1;
  }
};

class RestBuilder {
 public:
  RestBuilder(const Mesh& mesh, const RestState& rest, const std::vector<Hinge>& hinges,
              double stiffness, const MidedgeOptions& options)
      : mesh_(mesh), rest_(rest), hinges_(hinges), options_(options),
        C_(plateMatrix(stiffness, options.poissonRatio)) {
    edgeHinges_.assign(mesh.triangles.size(), {{-1, -1, -1}});
    for (std::size_t h = 0; h < hinges.size(); ++h) {
      for (Index t : hinges[h].triangles) {
        edgeHinges_[t][localEdge(t, hinges[h].vertices[0], hinges[h].vertices[1])] = static_cast<int>(h);
      }
    }
  }

  bool isHeld(Index t) const {
    if (options_.held.empty()) return false;
    const Triangle& tri = mesh_.triangles[t];
    return options_.held[tri[0]] && options_.held[tri[1]] && options_.held[tri[2]];
  }

  /// The element of triangle t; numHinges = 0 when it has no energy.
  MidedgeElement element(Index t) const {
    const Neighbourhood n = neighbourhood(t);
    MidedgeElement e;
    e.triangle = t;
    const Eigen::Matrix<double, 3, kMaxHinges> tilts = tiltsOnHinges(n);
    const MidedgeElement::Factor F = stiffnessFactor(n, tilts);
    if (F.isZero(0.0)) return e;
    // Hinges the energy does not read (a correction that vanishes: on makeGrid's checkerboard
    // only the neighbours' diagonals enter) are left out, so that they do not widen the
    // Hessian's pattern; "does not read" is a column 1e-13 of the largest, round-off.
    const double largest = F.colwise().norm().maxCoeff();
    for (std::size_t s = 0; s < n.hinges.size(); ++s) {
      if (!(F.col(static_cast<Eigen::Index>(s)).norm() > 1e-13 * largest)) continue;
      const int slot = e.numHinges++;
      e.hinges[slot] = n.hinges[s].hinge;
      e.factor.col(slot) = F.col(static_cast<Eigen::Index>(s));
      for (int a = 0; a < 4; ++a) {
        const Index v = n.hinges[s].vertices[a];
        int vertex = 0;
        while (vertex < e.numVertices && e.vertices[vertex] != v) ++vertex;
        if (vertex == e.numVertices) e.vertices[e.numVertices++] = v;
        e.hingeVertexSlots[slot][a] = vertex;
      }
    }
    return e;
  }

 private:
  Vector3d restPoint(Index v) const { return mesh_.restPositions.segment<3>(3 * v); }
  double restDistance(Index a, Index b) const { return (restPoint(a) - restPoint(b)).norm(); }

  int localEdge(Index t, Index a, Index b) const {
    const Triangle& tri = mesh_.triangles[t];
    for (int k = 0; k < 3; ++k) {
      const Index p = tri[(k + 1) % 3], q = tri[(k + 2) % 3];
      if ((p == a && q == b) || (p == b && q == a)) return k;
    }
    return 0;  // not reached: the hinge's edge is an edge of both its triangles
  }

  Index otherTriangle(int hinge, Index t) const {
    const Hinge& h = hinges_[static_cast<std::size_t>(hinge)];
    return h.triangles[0] == t ? h.triangles[1] : h.triangles[0];
  }

  /// The triangle across edge k of `from` (placed), unfolded into the chart.
  ChartTriangle placeAcross(const ChartTriangle& from, int k, Index neighbour) const {
    const Index a = from.vertices[(k + 1) % 3], b = from.vertices[(k + 2) % 3];
    ChartTriangle c;
    c.triangle = neighbour;
    const Triangle& tri = mesh_.triangles[neighbour];
    for (int j = 0; j < 3; ++j) {
      const Index v = tri[j];
      c.vertices[j] = v;
      if (v == a || v == b) {
        c.points[j] = from.pointOf(v);
      } else {
        c.points[j] = unfold(from.pointOf(a), from.pointOf(b), restDistance(v, a), restDistance(v, b),
                             from.points[k]);
      }
    }
    return c;
  }

  void addHinge(Neighbourhood& n, int hinge, const ChartTriangle& a, const ChartTriangle& b,
                int owner) const {
    int slot = n.slotOf(hinge);
    if (slot < 0) {
      slot = static_cast<int>(n.hinges.size());
      n.hinges.push_back(placeHinge(hinges_[static_cast<std::size_t>(hinge)], hinge, a, b));
    }
    n.hingesOf[owner].push_back(slot);
  }

  Neighbourhood neighbourhood(Index t) const {
    Neighbourhood n;
    const Triangle& tri = mesh_.triangles[t];
    n.self.triangle = t;
    n.self.vertices = tri;
    // t in its rest plane: x0 at the origin, x1 on the x axis, x2 above it (counter-clockwise in
    // the vertex order, so the chart's +z is t's normal).
    const double l01 = restDistance(tri[0], tri[1]);
    const double d02 = restDistance(tri[0], tri[2]), d12 = restDistance(tri[1], tri[2]);
    n.self.points[0] = Vector2d::Zero();
    n.self.points[1] = Vector2d(l01, 0.0);
    n.self.points[2] = unfold(n.self.points[0], n.self.points[1], d02, d12, Vector2d(0.0, -1.0));
    n.edgeHinge = edgeHinges_[t];
    for (int k = 0; k < 3; ++k) {
      if (n.edgeHinge[k] < 0) continue;
      n.across[k] = placeAcross(n.self, k, otherTriangle(n.edgeHinge[k], t));
      addHinge(n, n.edgeHinge[k], n.self, n.across[k], 0);
    }
    for (int k = 0; k < 3; ++k) {
      if (n.edgeHinge[k] < 0) continue;
      const ChartTriangle& u = n.across[k];
      n.hingesOf[k + 1].push_back(n.slotOf(n.edgeHinge[k]));
      for (int j = 0; j < 3; ++j) {
        const int hinge = edgeHinges_[u.triangle][j];
        if (hinge < 0 || hinge == n.edgeHinge[k]) continue;
        const Index w = otherTriangle(hinge, u.triangle);
        if (w == t || n.hinges.size() >= static_cast<std::size_t>(kMaxHinges)) continue;
        addHinge(n, hinge, u, placeAcross(u, j, w), k + 1);
      }
    }
    return n;
  }

  /// The curvature of triangle `owner` of the neighbourhood estimated from its hinges' angles:
  /// the smallest-energy curvature that reproduces them (exact when all three are known and the
  /// surface is quadratic). Hinges to a held triangle do not count (their angle is a slope, not a
  /// curvature); a held triangle has no estimate.
  bool curvatureEstimate(const Neighbourhood& n, int owner, TensorOnHinges* estimate) const {
    const Index tri = owner == 0 ? n.self.triangle : n.across[owner - 1].triangle;
    if (isHeld(tri)) return false;
    std::vector<int> used;
    for (int slot : n.hingesOf[owner]) {
      const Hinge& h = hinges_[static_cast<std::size_t>(n.hinges[slot].hinge)];
      if (!isHeld(h.triangles[0]) && !isHeld(h.triangles[1])) used.push_back(slot);
    }
    if (used.empty()) return false;
    const int k = static_cast<int>(used.size());
    Eigen::MatrixXd L(k, 3);
    for (int r = 0; r < k; ++r) L.row(r) = n.hinges[used[r]].curvature.transpose();
    const Matrix3d Cinv = C_.inverse();
    const Eigen::MatrixXd R =
        Cinv * L.transpose() * (L * Cinv * L.transpose()).completeOrthogonalDecomposition().pseudoInverse();
    estimate->setZero();
    for (int r = 0; r < k; ++r) estimate->col(used[r]) += R.col(r);
    return true;
  }

  /// Row k: the tilt phi_k of the mid-edge normal of t's edge k away from t, as a linear
  /// function of the stencil hinges' angles (zero rows for boundary edges, which are free).
  Eigen::Matrix<double, 3, kMaxHinges> tiltsOnHinges(const Neighbourhood& n) const {
    Eigen::Matrix<double, 3, kMaxHinges> tilts = Eigen::Matrix<double, 3, kMaxHinges>::Zero();
    std::array<TensorOnHinges, 4> estimates;
    std::array<bool, 4> known{};
    for (int owner = 0; owner < 4; ++owner) {
      known[owner] = (owner == 0 || n.edgeHinge[owner - 1] >= 0) &&
                     curvatureEstimate(n, owner, &estimates[owner]);
    }
    const bool selfHeld = isHeld(n.self.triangle);
    for (int k = 0; k < 3; ++k) {
      if (n.edgeHinge[k] < 0) continue;
      const int slot = n.slotOf(n.edgeHinge[k]);
      const ChartTriangle& u = n.across[k];
      const bool otherHeld = isHeld(u.triangle);
      if (selfHeld && !otherHeld) continue;  // the clamp's own director: no tilt
      const EdgeGeometry g = edgeGeometry(n, k);
      if (otherHeld && !selfHeld) {
        tilts(k, slot) = 2.0 * g.halfJump;  // the director is the clamp plate's normal
        continue;
      }
      tilts(k, slot) = g.halfJump;
      TensorOnHinges average = TensorOnHinges::Zero();
      int count = 0;
      for (int owner : {0, k + 1}) {
        if (known[owner]) {
          average += estimates[owner];
          ++count;
        }
      }
      if (count > 0) tilts.row(k) += g.deviation.transpose() * average / count;
    }
    return tilts;
  }

  struct EdgeGeometry {
    double halfJump = 0.0;           // (g_u - g_t) . n / 2 = halfJump * theta_e
    Voigt deviation = Voigt::Zero();  // exact mid-edge slope minus the average, per curvature
  };

  /// For t's edge k: how the bisector's tilt relates to the hinge angle, and how far the
  /// averaged face slope across the edge is from the exact one for quadratic height fields.
  EdgeGeometry edgeGeometry(const Neighbourhood& n, int k) const {
    const ChartTriangle& t = n.self;
    const ChartTriangle& u = n.across[k];
    const ChartHinge& hinge = n.hinges[static_cast<std::size_t>(n.slotOf(n.edgeHinge[k]))];
    const Vector2d a = t.points[(k + 1) % 3], b = t.points[(k + 2) % 3];
    const Vector2d mid = 0.5 * (a + b);
    Vector2d normal((b - a).y(), -(b - a).x());
    normal.normalize();
    if (normal.dot(t.points[k] - a) > 0.0) normal = -normal;  // out of t
    const Eigen::Matrix<double, 2, 3> Gt = t.gradientWeights(), Gu = u.gradientWeights();
    // The tilt's part from the face slopes, on the hinge's four vertices.
    Eigen::Vector4d jump = Eigen::Vector4d::Zero();
    for (int j = 0; j < 3; ++j) {
      for (int c = 0; c < 4; ++c) {
        if (hinge.vertices[c] == t.vertices[j]) jump[c] -= 0.5 * normal.dot(Gt.col(j));
        if (hinge.vertices[c] == u.vertices[j]) jump[c] += 0.5 * normal.dot(Gu.col(j));
      }
    }
    EdgeGeometry g;
    g.halfJump = jump.dot(hinge.weights) / hinge.weights.squaredNorm();
    Eigen::Matrix<double, 3, 3> valuesT, valuesU;  // monomial values at the vertices (rows)
    for (int j = 0; j < 3; ++j) {
      valuesT.row(j) = monomials(t.points[j] - mid).transpose();
      valuesU.row(j) = monomials(u.points[j] - mid).transpose();
    }
    // Centred at the midpoint, every monomial's exact slope there is zero.
    const Eigen::Matrix<double, 2, 3> slopeT = Gt * valuesT, slopeU = Gu * valuesU;
    g.deviation = -0.5 * (normal.transpose() * (slopeT + slopeU)).transpose();
    return g;
  }

  /// F with K = F^T F = B_r^T M~ B_r: the triangle's 3 x 3 plate form M on its tilts, with the
  /// free tilts of boundary edges minimised out (M~, a Schur complement), expressed on the
  /// stencil hinges through the known tilts B_r; F = L^T B_r with M~ = L L^T.
  MidedgeElement::Factor stiffnessFactor(const Neighbourhood& n,
                                         const Eigen::Matrix<double, 3, kMaxHinges>& tilts) const {
    const ChartTriangle& t = n.self;
    const double area = rest_.restArea[t.triangle];
    Matrix3d N;  // tilts -> curvature (Voigt)
    for (int k = 0; k < 3; ++k) {
      const Vector2d e = t.points[(k + 2) % 3] - t.points[(k + 1) % 3];
      const Vector2d normal = Vector2d(e.y(), -e.x()).normalized();
      N.col(k) = e.norm() / area * outerVoigt(normal);
    }
    const Matrix3d M = area * N.transpose() * C_ * N;
    std::vector<int> known, free;
    for (int k = 0; k < 3; ++k) (n.edgeHinge[k] >= 0 ? known : free).push_back(k);
    MidedgeElement::Factor F = MidedgeElement::Factor::Zero();
    if (known.empty()) return F;
    const int r = static_cast<int>(known.size()), f = static_cast<int>(free.size());
    Eigen::MatrixXd Mrr(r, r), Mrf(r, f), Mff(f, f), B(r, kMaxHinges);
    for (int i = 0; i < r; ++i) {
      B.row(i) = tilts.row(known[i]);
      for (int j = 0; j < r; ++j) Mrr(i, j) = M(known[i], known[j]);
      for (int j = 0; j < f; ++j) Mrf(i, j) = M(known[i], free[j]);
    }
    for (int i = 0; i < f; ++i) {
      for (int j = 0; j < f; ++j) Mff(i, j) = M(free[i], free[j]);
    }
    Eigen::MatrixXd reduced = Mrr;
    if (f > 0) reduced -= Mrf * Mff.ldlt().solve(Mrf.transpose());
    // A Schur complement of the positive definite M: positive definite.
    const Eigen::MatrixXd L = reduced.llt().matrixL();
    F.topRows(r) = L.transpose() * B;
    return F;
  }

  const Mesh& mesh_;
  const RestState& rest_;
  const std::vector<Hinge>& hinges_;
  const MidedgeOptions& options_;
  const Matrix3d C_;
  std::vector<std::array<int, 3>> edgeHinges_;
};

/// Adds a (3 * numVertices)^2 element matrix into the Hessian at the element's pair offsets.
template <class Matrix>
void scatterElement(const Matrix& Ke, const MidedgeElement& e, const int* pairOffset,
                    const std::vector<int>& columnStride, double* values) {
  for (int p = 0; p < e.numVertices; ++p) {
    for (int q = 0; q < e.numVertices; ++q) {
      const int first = pairOffset[p * kElementVertices + q];
      const int stride = columnStride[e.vertices[q]];
      for (int l = 0; l < 3; ++l) {
        for (int k = 0; k < 3; ++k) values[first + l * stride + k] += Ke(3 * p + k, 3 * q + l);
      }
    }
  }
}

/// (F J)^T (F J) for an element, J the rows db/dx of its hinge slots on its vertices (given by
/// `measureGradient(slot)`): its Gauss-Newton Hessian, PSD and symmetric to the last bit.
template <class GradientOf>
void gaussNewton(const MidedgeElement& e, const GradientOf& measureGradient,
                 MidedgeBending::ElementHessian* Ke) {
  Eigen::Matrix<double, 3, 3 * kElementVertices> FJ = Eigen::Matrix<double, 3, 3 * kElementVertices>::Zero();
  for (int s = 0; s < e.numHinges; ++s) {
    const HingeVector& g = measureGradient(s);
    for (int a = 0; a < 4; ++a) {
      FJ.middleCols<3>(3 * e.hingeVertexSlots[s][a]) += e.factor.col(s) * g.segment<3>(3 * a).transpose();
    }
  }
  const int n = 3 * e.numVertices;
  Ke->setZero();
  for (int j = 0; j < n; ++j) {
    for (int i = j; i < n; ++i) {
      const double v = FJ.col(i).dot(FJ.col(j));
      (*Ke)(i, j) = v;
      (*Ke)(j, i) = v;
    }
  }
}

}  // namespace

double midedgeMeasureOfAngle(double theta) { return 2.0 * std::tan(0.5 * theta); }

bool midedgeHingeMeasure(const HingePositions& x, double restMeasure, double* measure,
                         HingeVector* gradient, HingeMatrix* hessian) {
  double theta = 0.0;
  HingeVector dtheta;
  HingeMatrix d2theta;
  const bool derivatives = gradient != nullptr || hessian != nullptr;
  if (!dihedralAngle(x, &theta, derivatives ? &dtheta : nullptr, hessian ? &d2theta : nullptr)) {
    return false;
  }
  // cos(theta / 2) ~ (pi - |theta|) / 2: a hinge folded flat has no finite measure.
  if (!(std::cos(0.5 * theta) > 0.5e-6)) return false;
  const double t = std::tan(0.5 * theta);
  *measure = 2.0 * t - restMeasure;
  const double slope = 1.0 + t * t;  // d(2 tan(theta / 2)) / d theta
  if (gradient != nullptr) *gradient = slope * dtheta;
  if (hessian != nullptr) {
    const HingeMatrix H = slope * d2theta + (t * slope) * (dtheta * dtheta.transpose());
    // Eigen may fold the scalar into one factor of the outer product: symmetrise exactly.
    *hessian = 0.5 * (H + H.transpose());
  }
  return true;
}

MidedgeBending::MidedgeBending(const Mesh& mesh, const RestState& rest, double stiffness,
                               const MidedgeOptions& options)
    : HingeTerm(mesh, stiffness), poissonRatio_(options.poissonRatio) {
  const std::size_t m = hinges_.size();
  restMeasures_.resize(m);
  for (std::size_t h = 0; h < m; ++h) {
    double theta = 0.0;
    // Rest triangles have positive area (computeRestState), so the angle is defined.
    dihedralAngle(hingePositions(mesh.restPositions, hinges_[h]), &theta);
    restMeasures_[h] = midedgeMeasureOfAngle(theta);
  }
  const RestBuilder builder(mesh, rest, hinges_, stiffness, options);
  for (Index t = 0; t < mesh.numTriangles(); ++t) {
    MidedgeElement e = builder.element(t);
    if (e.numHinges > 0) elements_.push_back(e);
  }
  std::vector<int> uses(m, 0);
  for (const MidedgeElement& e : elements_) {
    for (int s = 0; s < e.numHinges; ++s) ++uses[static_cast<std::size_t>(e.hinges[s])];
  }
  hingeUseStart_.assign(m + 1, 0);
  for (std::size_t h = 0; h < m; ++h) hingeUseStart_[h + 1] = hingeUseStart_[h] + uses[h];
  hingeUses_.resize(static_cast<std::size_t>(hingeUseStart_[m]));
  std::vector<int> next(hingeUseStart_.begin(), hingeUseStart_.end() - 1);
  for (std::size_t e = 0; e < elements_.size(); ++e) {
    for (int s = 0; s < elements_[e].numHinges; ++s) {
      const auto h = static_cast<std::size_t>(elements_[e].hinges[s]);
      hingeUses_[static_cast<std::size_t>(next[h]++)] = {static_cast<int>(e), s};
    }
  }
  measure_.assign(m, 0.0);
  moment_.assign(m, 0.0);
  measureGradient_.assign(m, HingeVector::Zero());
  elementMoment_.assign(elements_.size(), {});
}

void MidedgeBending::appendStencils(std::vector<std::vector<Index>>* stencils) const {
  for (const MidedgeElement& e : elements_) {
    stencils->emplace_back(e.vertices.begin(), e.vertices.begin() + e.numVertices);
  }
}

void MidedgeBending::bindHessian(const SparseHessian& hessian) {
  HingeTerm::bindHessian(hessian);
  curvatureHessian_.resize(hinges_.size());
  pairOffset_.assign(elements_.size() * kElementVertices * kElementVertices, -1);
  for (std::size_t i = 0; i < elements_.size(); ++i) {
    const MidedgeElement& e = elements_[i];
    for (int p = 0; p < e.numVertices; ++p) {
      for (int q = 0; q < e.numVertices; ++q) {
        pairOffset_[i * kElementVertices * kElementVertices + p * kElementVertices + q] =
            hessian.blockColumnOffset(e.vertices[p], e.vertices[q], 0);
      }
    }
  }
  columnStride_.resize(static_cast<std::size_t>(hessian.numVertices()));
  for (Index v = 0; v < hessian.numVertices(); ++v) {
    columnStride_[v] = hessian.blockColumnOffset(v, v, 1) - hessian.blockColumnOffset(v, v, 0);
  }
}

EvalResult MidedgeBending::evaluate(const VectorX& x, const EvalRequest& request) {
  const Index m = static_cast<Index>(hinges_.size());
  const Index numElements = static_cast<Index>(elements_.size());
  const bool wantGradient = request.gradient != nullptr;
  const bool wantHessian = request.hessian != nullptr;
  const bool project = request.hessianMode == HessianMode::Projected;
#pragma omp parallel for schedule(static) if (m >= kParallelElementThreshold)
  for (Index h = 0; h < m; ++h) {
    inDomain_[h] = midedgeHingeMeasure(gather(x, h), restMeasures_[h], &measure_[h],
                                       (wantGradient || wantHessian) ? &measureGradient_[h] : nullptr,
                                       wantHessian ? &curvatureHessian_[h] : nullptr);
  }
  for (Index h = 0; h < m; ++h) {
    if (!inDomain_[h]) {
      // The measures the moments read are undefined: report, touch nothing.
      EvalResult bad;
      bad.inDomain = false;
      bad.firstBadElement = h;
      bad.energy = kInfiniteEnergy;
      return bad;
    }
  }
#pragma omp parallel for schedule(static) if (numElements >= kParallelElementThreshold)
  for (Index i = 0; i < numElements; ++i) {
    const MidedgeElement& e = elements_[i];
    Eigen::Matrix<double, kMaxHinges, 1> b = Eigen::Matrix<double, kMaxHinges, 1>::Zero();
    for (int s = 0; s < e.numHinges; ++s) b[s] = measure_[e.hinges[s]];
    const Eigen::Matrix<double, kMaxHinges, 1> mu = e.factor.transpose() * (e.factor * b);
    for (int s = 0; s < kMaxHinges; ++s) elementMoment_[i][s] = mu[s];
  }
#pragma omp parallel for schedule(static) if (m >= kParallelElementThreshold)
  for (Index h = 0; h < m; ++h) {
    double moment = 0.0;
    for (int u = hingeUseStart_[h]; u < hingeUseStart_[h + 1]; ++u) {
      moment += elementMoment_[hingeUses_[u][0]][hingeUses_[u][1]];
    }
    moment_[h] = moment;
    // E = sum_t 1/2 b_t . (K_t b_t) = sum_h 1/2 b_h m_h.
    energy_[h] = 0.5 * measure_[h] * moment;
    if (wantGradient) gradient_[h] = moment * measureGradient_[h];
    if (wantHessian) {
      curvatureHessian_[h] *= moment;
      if (project) curvatureHessian_[h] = clampNegativeEigenvalues(curvatureHessian_[h]);
    }
  }
  const EvalResult result = reduce(request);
  if (wantHessian) {
    for (Index h = 0; h < m; ++h) request.hessian->addElement<12>(curvatureHessian_[h], offsets(h));
    addGaussNewton(*request.hessian);
  }
  return result;
}

void MidedgeBending::addGaussNewton(SparseHessian& hessian) const {
  double* values = hessian.values();
  ElementHessian Ke;
  for (std::size_t i = 0; i < elements_.size(); ++i) {
    const MidedgeElement& e = elements_[i];
    gaussNewton(e, [&](int s) -> const HingeVector& { return measureGradient_[e.hinges[s]]; }, &Ke);
    scatterElement(Ke, e, &pairOffset_[i * kElementVertices * kElementVertices], columnStride_, values);
  }
}

bool MidedgeBending::evaluateElement(Index index, const VectorX& x, double* energy,
                                     ElementGradient* gradient, ElementHessian* hessian,
                                     HessianMode mode) const {
  const MidedgeElement& e = elements_[static_cast<std::size_t>(index)];
  Eigen::Matrix<double, kMaxHinges, 1> b = Eigen::Matrix<double, kMaxHinges, 1>::Zero();
  std::array<HingeVector, kMaxHinges> db;
  std::array<HingeMatrix, kMaxHinges> d2b;
  const bool derivatives = gradient != nullptr || hessian != nullptr;
  for (int s = 0; s < e.numHinges; ++s) {
    const auto h = static_cast<std::size_t>(e.hinges[s]);
    if (!midedgeHingeMeasure(hingePositions(x, hinges_[h]), restMeasures_[h], &b[s],
                             derivatives ? &db[s] : nullptr, hessian ? &d2b[s] : nullptr)) {
      return false;
    }
  }
  const Eigen::Vector3d Fb = e.factor * b;
  const Eigen::Matrix<double, kMaxHinges, 1> mu = e.factor.transpose() * Fb;
  if (energy != nullptr) *energy = 0.5 * Fb.squaredNorm();
  if (gradient != nullptr) {
    gradient->setZero();
    for (int s = 0; s < e.numHinges; ++s) {
      for (int a = 0; a < 4; ++a) {
        gradient->segment<3>(3 * e.hingeVertexSlots[s][a]) += mu[s] * db[s].segment<3>(3 * a);
      }
    }
  }
  if (hessian == nullptr) return true;
  gaussNewton(e, [&](int s) -> const HingeVector& { return db[s]; }, hessian);
  for (int s = 0; s < e.numHinges; ++s) {
    HingeMatrix part = mu[s] * d2b[s];
    if (mode == HessianMode::Projected) part = clampNegativeEigenvalues(part);
    for (int a = 0; a < 4; ++a) {
      for (int c = 0; c < 4; ++c) {
        hessian->block<3, 3>(3 * e.hingeVertexSlots[s][a], 3 * e.hingeVertexSlots[s][c]) +=
            part.block<3, 3>(3 * a, 3 * c);
      }
    }
  }
  return true;
}

bool MidedgeBending::vertexDerivatives(const VectorX& x, Index vertex, HessianMode mode,
                                       VertexDerivatives& out) const {
  if (!incidence_.isBuilt()) return false;  // not prepared
  out = VertexDerivatives{};
  ElementGradient gradient;
  ElementHessian hessian;
  for (const VertexIncidence::Use& use : incidence_.uses(vertex)) {
    if (!evaluateElement(use.element, x, nullptr, &gradient, &hessian, mode)) return false;
    out.force -= gradient.segment<3>(3 * use.slot);
    out.hessian += hessian.block<3, 3>(3 * use.slot, 3 * use.slot);
  }
  return true;
}

}  // namespace fem_cloth
