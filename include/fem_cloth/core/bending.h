// Bending energies of a cloth (3D) triangle mesh, defined on hinges: pairs of triangles that
// share an edge. The default model, MidedgeBending (bending_midedge.h), converges to
// Kirchhoff-Love plate theory with a bending Poisson ratio, free edges included. Two simpler
// models:
//  - QuadraticBending: Bergou, Wardetzky, Harmon, Zorin, Grinspun, "A Quadratic Bending Model
//    for Inextensible Surfaces" (SGP 2006). Quadratic in x, so its Hessian is constant (and PSD);
//    cheap for implicit steps. Exact for isometric bending of a flat rest shape only.
//  - DihedralBending: Grinspun, Hirani, Desbrun, Schroeder, "Discrete Shells" (SCA 2003). A
//    function of the dihedral angles; preserves any (also curved) rest shape; its Hessian changes
//    every step and is made PSD per hinge on request.
//
// Both are scaled to the plate energy E = (k/2) * integral (kappa1 + kappa2)^2 dA with the
// bending stiffness k (N m = J) of bendingStiffness(): for a smooth isometric bending of a flat
// sheet the discrete energies converge to it as the mesh is refined (on regular meshes; see
// docs/bending.md for the calibration and its limits). That is the plate energy with a bending
// Poisson ratio of 1, which a saddle does not resist: free edges let it bend too far.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "fem_cloth/core/bending_model.h"
#include "fem_cloth/core/energy_forms.h"
#include "fem_cloth/core/energy_term.h"
#include "fem_cloth/core/expected.h"
#include "fem_cloth/core/mesh.h"
#include "fem_cloth/core/rest_state.h"

namespace fem_cloth {

/// An interior edge with its two triangles. vertices = {x0, x1, x2, x3}: the edge x0-x1 in the
/// order it has in triangles[0], x2 the vertex of triangles[0] opposite the edge, x3 the one of
/// triangles[1]. The orientation of triangles[1] does not matter: every quantity of a hinge is
/// computed from these four vertices in this order.
struct Hinge {
  std::array<Index, 4> vertices{};
  std::array<Index, 2> triangles{};
};

/// The hinges of a mesh, one per edge shared by exactly two triangles, ordered by edge (i < j).
/// Boundary edges (one triangle) and non-manifold edges (three or more triangles: no unique pair
/// to bend between) carry no hinge; nor does an edge whose two triangles have the same third
/// vertex (a repeated triangle, which validateMesh rejects).
std::vector<Hinge> buildHinges(const Mesh& mesh);

/// Bending stiffness of a thin isotropic plate, k = E h^3 / (12 (1 - nu^2)) (Timoshenko &
/// Woinowsky-Krieger, "Theory of Plates and Shells", 1959, eq. 3), in N m (= J) for Young's
/// modulus E in Pa and thickness h in m.
double bendingStiffness(double youngsModulus, double thickness, double poissonRatio);

/// Positions of a hinge's vertices x0..x3 as columns (m); flat index 3*a + k for vertex a,
/// coordinate k (the layout of conventions.h restricted to the hinge).
using HingePositions = Eigen::Matrix<double, 3, 4>;
using HingeVector = Eigen::Matrix<double, 12, 1>;
using HingeMatrix = Eigen::Matrix<double, 12, 12>;

/// The signed dihedral (bending) angle theta of a hinge in (-pi, pi], zero when the two
/// triangles are coplanar and unfolded. With e = x1 - x0, n1 = e x (x2 - x0) and
/// n2 = (x3 - x0) x e (the normals of triangles (x0, x1, x2) and (x0, x3, x1)),
/// theta = atan2((n1 x n2) . e / |e|, n1 . n2), an atan2 form that stays accurate near 0 and pi.
/// theta > 0 when x3 lies on the side of n1 opposite to n1's direction (the hinge folds away
/// from n1). Fills dtheta/dx and d2theta/dx2 when asked (null = not needed). Returns false,
/// touching nothing, if the edge or a triangle is degenerate (zero length or area): the angle
/// is then undefined.
bool dihedralAngle(const HingePositions& x, double* angle, HingeVector* gradient = nullptr,
                   HingeMatrix* hessian = nullptr);

/// The positions of a hinge's vertices x0..x3 taken from the flat positions x (d = 3).
HingePositions hingePositions(const VectorX& x, const Hinge& hinge);

/// The closest PSD matrix (Frobenius norm): the negative eigenvalues set to zero, symmetric to
/// the last bit.
HingeMatrix clampNegativeEigenvalues(const HingeMatrix& H);

/// Shared machinery of the hinge-based terms: the hinges, their Hessian stencils and cached
/// offsets, the per-hinge energy and gradient buffers, and their fixed-order reduction. Hinge
/// work runs in parallel (OpenMP, when built with it) into the buffers, which are then summed in
/// hinge order: the result is bit-identical for any number of threads, and a steady-state
/// evaluation allocates nothing.
class HingeTerm : public EnergyTerm {
 public:
  const std::vector<Hinge>& hinges() const { return hinges_; }
  /// k (N m).
  double stiffness() const { return stiffness_; }

  void appendStencils(std::vector<std::vector<Index>>* stencils) const override;
  void bindHessian(const SparseHessian& hessian) override;
  /// Every hinge-based model offers per-vertex access (EnergyTerm::vertexDerivatives), once
  /// prepared: the table of the stencils (appendStencils) around each vertex, built once.
  bool hasVertexDerivatives() const override { return true; }
  void prepareVertexAccess() override;

 protected:
  /// Preconditions (checked by makeBendingTerm): a 3D mesh, rest computed from it, finite k >= 0.
  HingeTerm(const Mesh& mesh, double stiffness);

  HingePositions gather(const VectorX& x, std::size_t hinge) const;
  /// Sums energy_ and gradient_ of the hinges in domain, in hinge order, into the result and
  /// request.gradient (the Hessian is the derived term's part).
  EvalResult reduce(const EvalRequest& request) const;
  /// Hessian offsets of hinge h, laid out as SparseHessian::stencilOffsets.
  const int* offsets(std::size_t hinge) const { return &offsets_[hinge * kOffsetsPerHinge]; }

  static constexpr std::size_t kOffsetsPerHinge = 4 * 4 * 3;

  double stiffness_;
  Index numVertices_;
  std::vector<Hinge> hinges_;
  std::vector<double> energy_;
  std::vector<char> inDomain_;
  std::vector<HingeVector, Eigen::aligned_allocator<HingeVector>> gradient_;
  std::vector<int> offsets_;
  /// The stencils (hinges; the mid-edge model's elements) around each vertex; empty until
  /// prepareVertexAccess().
  VertexIncidence incidence_;
};

/// Bergou et al. 2006, the discrete isometric bending model (the paper's K0 and Q_e). Per hinge,
///   K = (c03 + c04, c01 + c02, -c01 - c03, -c02 - c04)
/// from the cotangents of the interior rest angles at the edge's ends (c01, c02 at x0 in the
/// triangles with x2, x3; c03, c04 at x1 likewise), and
///   E = sum_hinges (k / 2) |sum_a K_a x_a|^2 / (A1 + A2)   (A1, A2 the rest triangle areas),
/// i.e. (1/2) x^T Q x per coordinate with a constant, PSD Q. sum_a K_a x_a is the hinge's
/// discrete mean-curvature normal (length 2 |e| sin(theta/2) for a fold): K annihilates every
/// affine function of a flat rest hinge, so E is zero for any affine (in particular rigid or
/// flattening) map of a flat rest mesh. Summed over the hinges, x^T Q_e x with the paper's
/// Q_e = 3 K^T K / (A1 + A2) approaches 3 integral (kappa1 + kappa2)^2 dA for isometric bending,
/// so E = (k/6) sum x^T Q_e x is the Kirchhoff energy (see DihedralBending for the cylinder).
/// Assumes a flat rest state: for a curved rest shape the energy measures bending away from flat
/// (the rest state itself has energy); use DihedralBending to keep a curved rest shape.
/// A hinge term with a constraint form (energy_forms.h), one element per hinge; the derived term
/// gives the constraints.
class HingeConstraintTerm : public HingeTerm, public ConstraintForm {
 public:
  const ConstraintForm* constraintForm() const override { return this; }
  Index numElements() const override { return static_cast<Index>(hinges_.size()); }
  int verticesPerElement() const override { return 4; }
  const Index* elementVertices(Index hinge) const override {
    return hinges_[static_cast<std::size_t>(hinge)].vertices.data();
  }

 protected:
  using HingeTerm::HingeTerm;
};

class QuadraticBending final : public HingeConstraintTerm, public ProjectiveForm {
 public:
  QuadraticBending(const Mesh& mesh, const RestState& rest, double stiffness);

  std::string name() const override { return "bending/quadratic"; }
  EvalResult evaluate(const VectorX& x, const EvalRequest& request) override;
  bool hasConstantHessian() const override { return true; }
  /// Force -w K_a (sum_b K_b x_b) and block w K_a^2 I of each hinge around the vertex (PSD:
  /// both modes alike).
  bool vertexDerivatives(const VectorX& x, Index vertex, HessianMode mode,
                         VertexDerivatives& out) const override;

  /// Projective form: already quadratic, E = 1/2 x^T Q x with p = 0; nothing to project.
  ProjectiveForm* projectiveForm() override { return this; }
  void appendProjectiveMatrix(std::vector<Eigen::Triplet<double>>* triplets) const override;
  void addProjectiveRhs(const VectorX& /*x*/, VectorX* /*rhs*/) override {}

  /// Constraint form: C = sum_a K_a x_a (3 values, linear in x), K_e = weight I.
  int constraintsPerElement() const override { return 3; }
  bool elementConstraints(Index hinge, const VectorX& x, double* C, double* jacobian) const override;
  void elementConstraintStiffness(Index hinge, double* K) const override;

  /// K of each hinge (dimensionless) and its weight k / (A1 + A2) (N m / m^2).
  const std::vector<Eigen::Vector4d>& cotangentStencils() const { return stencils_; }
  const std::vector<double>& weights() const { return weights_; }

 private:
  std::vector<Eigen::Vector4d> stencils_;
  std::vector<double> weights_;
};

/// Grinspun et al. 2003, the flexural energy W_B:
///   E = sum_hinges k c_e (theta_e - restTheta_e)^2   with
///   c_e = (1/6) * 3 |e|^2 / (A1 + A2) = |e|^2 / (2 (A1 + A2))
/// from the rest edge length |e| and rest triangle areas A1, A2. 3 |e|^2 / (A1 + A2) is the
/// paper's |e| / h_e (h_e a third of the average of the two triangle heights); the factor 1/6
/// calibrates it to the Kirchhoff energy: on a cylinder of radius R every interior edge along the
/// axis of a regular grid bends by theta = a / R (a the spacing around the circumference), which
/// makes the paper's sum 3 (1 / R^2) per unit area, while (k/2)(kappa1 + kappa2)^2 = k / (2 R^2).
/// theta - restTheta is wrapped into [-pi, pi] so that the energy is continuous when a hinge
/// folds through theta = pi. The exact Hessian
///   2 k c_e (grad theta grad theta^T + (theta - restTheta) hess theta)
/// is indefinite away from rest; HessianMode::Projected clamps the negative eigenvalues of each
/// hinge's 12 x 12 Hessian to zero (the closest PSD matrix; exact when already PSD).
/// A hinge with a degenerate triangle at x is out of the domain (the angle is undefined).
class DihedralBending final : public HingeConstraintTerm {
 public:
  DihedralBending(const Mesh& mesh, const RestState& rest, double stiffness);

  std::string name() const override { return "bending/dihedral"; }
  EvalResult evaluate(const VectorX& x, const EvalRequest& request) override;
  void bindHessian(const SparseHessian& hessian) override;
  /// Projected: the block of each hinge's projected 12 x 12 Hessian, as evaluate() adds it.
  bool vertexDerivatives(const VectorX& x, Index vertex, HessianMode mode,
                         VertexDerivatives& out) const override;

  /// Constraint form: C = theta - restTheta (wrapped), K_e = 2 k c_e.
  int constraintsPerElement() const override { return 1; }
  bool elementConstraints(Index hinge, const VectorX& x, double* C, double* jacobian) const override;
  void elementConstraintStiffness(Index hinge, double* K) const override;

  /// restTheta of each hinge (rad) and k c_e (J / rad^2).
  const std::vector<double>& restAngles() const { return restAngles_; }
  const std::vector<double>& weights() const { return weights_; }

 private:
  std::vector<double> restAngles_;
  std::vector<double> weights_;
  std::vector<HingeMatrix, Eigen::aligned_allocator<HingeMatrix>> hessian_;
};

/// What a scene asks of its bending term.
struct BendingSpec {
  BendingModel model = BendingModel::Midedge;
  double stiffness = 0.0;     ///< k = D (N m), see bendingStiffness; 0: no term at all
  double poissonRatio = 0.0;  ///< midedge: the bending Poisson ratio nu_b, in [0, 0.5)
  /// midedge: per vertex (or empty), held for the whole run; triangles with three held vertices
  /// are clamp plates.
  std::vector<char> held;
};

/// The bending term of a cloth mesh. k = 0 returns nullptr: the term is not assembled at all.
/// Errors name the culprit: k negative or not finite, nu_b outside [0, 0.5), a held list of the
/// wrong size, a planar (dim 2) mesh, or a rest state that does not belong to the mesh.
Expected<std::unique_ptr<EnergyTerm>> makeBendingTerm(const Mesh& mesh, const RestState& rest,
                                                      const BendingSpec& spec);
/// The same with nu_b = 0 and nothing held, the model by name (bendingModelNames()): an unknown
/// name is an error listing the known ones.
Expected<std::unique_ptr<EnergyTerm>> makeBendingTerm(const Mesh& mesh, const RestState& rest,
                                                      const std::string& model, double stiffness);

}  // namespace fem_cloth
