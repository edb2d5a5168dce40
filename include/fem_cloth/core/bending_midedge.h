// Kirchhoff-Love bending of a cloth (3D) mesh on mid-edge normals: the plate energy
//
//   E = integral (D/2) [ (k1 + k2)^2 - 2 (1 - nu_b) k1 k2 ] dA
//     = integral (D/2) [ nu_b (tr S)^2 + (1 - nu_b) S : S ] dA
//
// with the bending rigidity D (N m), the bending Poisson ratio nu_b and the shape operator S of
// the deformed surface relative to its rest shape (flat or curved). It converges to plate theory
// under refinement, free edges included, on the grid meshes of makeGrid and on irregular meshes
// (docs/bending.md, docs/validation.md).
//
// The discretisation (docs/bending.md has the derivation):
//  - Each triangle t has a constant shape operator from the normals at its three edge midpoints
//    (Grinspun, Gingold, Reisman, Zorin, "Computing discrete shape operators on general meshes",
//    2006; Chen, Sastry, van Rees, Vouga, "Physical simulation of environmentally induced thin
//    shell deformation", 2018): S_t = (1 / A_t) sum_i l_i phi_i n_i n_i^T, where l_i and n_i
//    are the rest length and in-plane outer normal of edge i and phi_i the tilt of the edge's
//    mid-edge normal away from the triangle. One mid-edge normal per edge, shared by its two
//    triangles, is what makes the sum over triangles telescope (a constant moment field produces
//    no force: the patch test).
//  - The mid-edge normal is the bisector of the two face normals (phi = theta / 2 on both sides,
//    theta the hinge's bending angle) plus a correction delta_e that makes it exact for every
//    quadratic surface: for hinges whose two triangles do not form a parallelogram (the mirrored
//    hinges of makeGrid's checkerboard, irregular meshes) the bisector is wrong by O(h |grad S|)
//    for twist, which an averaged normal does not see. delta_e = d_e : S_e with a rest tensor
//    d_e and the curvature S_e estimated from the hinge angles of the edge's two triangles.
//    Without it the model converges, on the checkerboard grid, to a plate 20-40 % too stiff or
//    too soft depending on the load (measured, docs/bending.md).
//  - Free edges: the mid-edge normal of a boundary edge is free; the energy is minimised over it
//    in closed form (a Schur complement of the triangle's 3 x 3 form). That is the natural
//    boundary condition M_nn = 0 of a free edge.
//  - Held (clamped) triangles: a triangle whose three vertices are held (pinned by the scene for
//    its whole duration) is a clamp plate. The mid-edge normal of an edge between it and a free
//    triangle is the clamp plate's normal: the cloth leaves the clamp tangentially (the Morley
//    element's clamped edge), instead of pivoting half-way as the bisector would let it.
//  - Every quantity is a linear function of the hinges' bending measures
//    b = 2 tan(theta / 2) - 2 tan(rest theta / 2), with coefficients computed once from the rest
//    shape in a chart where the triangle's neighbourhood is unfolded flat. The energy is
//    E = sum_t 1/2 b_t^T K_t b_t with a constant PSD matrix K_t per triangle over the (up to 9)
//    hinges its shape operator reads. Hence rest energy zero for any rest shape, invariance under
//    rigid motions, and the exact Kirchhoff limit for every curvature. tan(theta / 2) (libshell's
//    MidedgeAngleTan choice) makes the energy grow without bound as a hinge folds flat, so it is
//    continuous through the fold (the coupled form has no symmetric wrap as the dihedral model).
//
// Derivatives: gradient sum_h m_h b_h'(theta) grad theta_h with the hinge moments
// m_h = sum_t (K_t b_t)_h; Hessian sum_t (F_t J_t)^T (F_t J_t) (PSD, J_t the rows grad b_h) plus
// sum_h m_h hess b_h. HessianMode::Projected clamps the negative eigenvalues of each hinge's
// 12 x 12 m_h hess b_h (the first sum is PSD already): a PSD matrix equal to the exact Hessian
// at rest.
#pragma once

#include <array>
#include <vector>

#include "fem_cloth/core/bending.h"

namespace fem_cloth {

/// The rest data of one triangle's bending element: the hinges its shape operator reads and the
/// constant matrix K = F^T F of its energy 1/2 b^T K b = 1/2 |F b|^2 over their bending
/// measures b. F has at most three rows (the triangle's three mid-edge tilts, less the free ones
/// of boundary edges), so K has rank <= 3.
struct MidedgeElement {
  static constexpr int kMaxHinges = 9;
  static constexpr int kMaxVertices = 12;
  using Factor = Eigen::Matrix<double, 3, kMaxHinges>;

  Index triangle = -1;
  int numHinges = 0;
  std::array<Index, kMaxHinges> hinges{};  ///< indices into MidedgeBending::hinges()
  int numVertices = 0;
  std::array<Index, kMaxVertices> vertices{};  ///< the mesh vertices of those hinges
  /// Where vertex a of hinge slot s sits in `vertices`.
  std::array<std::array<int, 4>, kMaxHinges> hingeVertexSlots{};
  /// F (sqrt(J)): only the first numHinges columns are non-zero.
  Factor factor = Factor::Zero();
  /// K = F^T F (J), numHinges x numHinges, symmetric PSD.
  Eigen::MatrixXd stiffness() const {
    return factor.leftCols(numHinges).transpose() * factor.leftCols(numHinges);
  }
};

/// A hinge's bending measure b = 2 tan(theta / 2) - 2 tan(restTheta / 2) and its derivatives
/// db/dx, d2b/dx2 (filled when asked, null = not needed). False, touching nothing, when the
/// hinge is degenerate (dihedralAngle) or folded flat to within 1e-6 rad (b unbounded there).
bool midedgeHingeMeasure(const HingePositions& x, double restMeasure, double* measure,
                         HingeVector* gradient = nullptr, HingeMatrix* hessian = nullptr);

/// 2 tan(theta / 2), the measure of a hinge at bending angle theta (rad).
double midedgeMeasureOfAngle(double theta);

/// The rest-shape options of the mid-edge model.
struct MidedgeOptions {
  double poissonRatio = 0.0;  ///< nu_b, in [0, 0.5)
  /// Per vertex (or empty): held for the whole run. Triangles with three held vertices are
  /// clamp plates (see the header comment).
  std::vector<char> held;
};

class MidedgeBending final : public HingeTerm {
 public:
  /// Preconditions (checked by makeBendingTerm): a 3D mesh, rest computed from it, finite
  /// D >= 0, 0 <= nu_b < 0.5, held empty or one entry per vertex.
  MidedgeBending(const Mesh& mesh, const RestState& rest, double stiffness,
                 const MidedgeOptions& options);

  std::string name() const override { return "bending/midedge"; }
  EvalResult evaluate(const VectorX& x, const EvalRequest& request) override;
  void appendStencils(std::vector<std::vector<Index>>* stencils) const override;
  void bindHessian(const SparseHessian& hessian) override;
  /// From evaluateElement over the elements around the vertex. Projected: each element's
  /// Hessian made PSD as evaluateElement does it (per element; the assembled term projects per
  /// hinge), so the block is PSD but need not be the assembled projected Hessian's block.
  bool vertexDerivatives(const VectorX& x, Index vertex, HessianMode mode,
                         VertexDerivatives& out) const override;

  // No constraint form (an element couples 12 vertices and up to 9 hinge measures): XPBD
  // refuses it (the integrator registry says so when the scene is loaded); use quadratic or
  // dihedral bending with XPBD.

  double poissonRatio() const { return poissonRatio_; }
  const std::vector<MidedgeElement>& elements() const { return elements_; }
  /// 2 tan(restTheta / 2) per hinge.
  const std::vector<double>& restMeasures() const { return restMeasures_; }

  // --- One element at a time (for solvers that visit vertices, e.g. vertex block descent) ------
  using ElementGradient = Eigen::Matrix<double, 3 * MidedgeElement::kMaxVertices, 1>;
  using ElementHessian =
      Eigen::Matrix<double, 3 * MidedgeElement::kMaxVertices, 3 * MidedgeElement::kMaxVertices>;
  /// Energy (J) of element e at x, its gradient and Hessian over its vertices (3 * a + k for
  /// element vertex a; entries beyond 3 * numVertices are zero), filled when asked. Summed over
  /// all elements they are the term's energy, gradient and exact Hessian. Projected adds
  /// J^T K J and, per hinge slot s, the PSD part of (K b)_s hess b_s: PSD, exact at rest (a
  /// per-element choice; the assembled term projects per hinge instead). False outside the
  /// domain. Thread-safe.
  bool evaluateElement(Index e, const VectorX& x, double* energy, ElementGradient* gradient,
                       ElementHessian* hessian, HessianMode mode = HessianMode::Exact) const;

 private:
  void addGaussNewton(SparseHessian& hessian) const;

  double poissonRatio_;
  std::vector<double> restMeasures_;
  std::vector<MidedgeElement> elements_;
  // Hinge -> (element, slot) pairs, CSR: the elements whose energy reads each hinge.
  std::vector<int> hingeUseStart_;
  std::vector<std::array<int, 2>> hingeUses_;
  // Evaluation buffers, per hinge and per element.
  std::vector<double> measure_, slope_, moment_;
  std::vector<HingeVector, Eigen::aligned_allocator<HingeVector>> measureGradient_;
  std::vector<HingeMatrix, Eigen::aligned_allocator<HingeMatrix>> curvatureHessian_;
  std::vector<std::array<double, MidedgeElement::kMaxHinges>> elementMoment_;
  // Hessian slots of each element's vertex pairs (column 0; column l is l * stride further).
  std::vector<int> pairOffset_;
  std::vector<int> columnStride_;  // per vertex: rows of its column block times 3
};

}  // namespace fem_cloth
