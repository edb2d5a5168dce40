// Aerodynamic drag and lift on cloth (docs/air.md): the normal/tangential drag model of cloth
// animation (Ling, Damodaran & Gay, "Aerodynamic force models for animating cloth motion in air
// flow", The Visual Computer 12, 1996; Keckeisen et al., "Modelling effects of wind fields in
// cloth animations", WSCG 2004). Per triangle, with v_r the mean of its vertices' velocities
// minus the wind, n its unit normal and A its (deformed) area,
//
//   f = -1/2 rho A [C_n |v_n| v_n + C_t |v_t| v_t],   v_n = (v_r . n) n,  v_t = v_r - v_n,
//
// shared equally by its three vertices; two-sided (the sign of n cancels). On an inclined
// triangle f is not parallel to v_r: its part across the wind is the lift.
//
// The force is the negative velocity gradient of the dissipation potential
//
//   D(v) = 1/2 rho A [C_n |v_n|^3 + C_t |v_t|^3] / 3,
//
// which is convex in v (its Hessian 1/2 rho A [2 C_n |v_n| n n^T + C_t (|v_t| P + v_t v_t^T /
// |v_t|)], P = I - n n^T, is PSD): the implicit integrators add h D to their incremental
// potential, with n and A lagged at the start of the substep, and Newton stays a minimisation.
// The explicit ones (symplectic Euler, XPBD's and projective dynamics' predictions) take the
// force at the substep's starting velocity, stable while h times the drag rate stays below 1
// (explicitRate()).
#pragma once

#include <memory>
#include <vector>

#include "fem_cloth/core/expected.h"
#include "fem_cloth/core/energy_term.h"
#include "fem_cloth/core/integrators/integrator.h"
#include "fem_cloth/core/mesh.h"
#include "fem_cloth/core/sparse_hessian.h"

namespace fem_cloth {

struct AirSettings {
  double density = 1.2;          ///< rho, kg/m^3 (air at 20 C, sea level)
  double normalDrag = 1.0;       ///< C_n, dimensionless (a flat plate across the flow: about 1.2)
  double tangentialDrag = 0.02;  ///< C_t, dimensionless (skin friction along the surface)
  Eigen::Vector3d wind = Eigen::Vector3d::Zero();  ///< air velocity, m/s
};

class AirModel {
 public:
  /// A 3D cloth mesh (the scene reader refuses air on planar meshes).
  AirModel(std::shared_ptr<const Mesh> mesh, AirSettings settings);
  const AirSettings& settings() const { return settings_; }

  /// Takes the triangles' unit normals and areas at x (the start of a substep).
  void lag(const VectorX& x);
  /// The air force (N per DOF) at vertex velocities v, into out (resized).
  void force(const VectorX& v, VectorX& out) const;
  /// D(v) (W), the sum over triangles.
  double dissipation(const VectorX& v) const;
  /// Adds scale x d^2 D / dv^2 at v into H (whose pattern couples each triangle's vertices).
  void addHessian(const VectorX& v, double scale, SparseHessian& H);
  /// Builds the table of each vertex's triangles vertexDerivatives reads (once: the mesh does
  /// not change; EnergyTerm::prepareVertexAccess's contract).
  void prepareVertexAccess();
  /// Per-vertex access (for local solvers): at the velocities v = gamma (x - xc), the air force
  /// on `vertex` (N) into out.force and d^2D/dv_v^2 (N s/m, PSD) into out.hessian, from the
  /// vertex's triangles only. Thread-safe. False, out untouched, before prepareVertexAccess().
  bool vertexDerivatives(const VectorX& x, const VectorX& xc, double gamma, Index vertex,
                         VertexDerivatives& out) const;
  /// A bound on the fastest decay rate (1/s) the drag gives any vertex at v (Gershgorin over
  /// d(force)/dv / m): an explicit substep h is stable and does not reverse the relative
  /// velocity while h x this is below 1.
  double explicitRate(const VectorX& v, const VectorX& vertexMasses) const;

 private:
  /// Per triangle: its relative velocity (the mean of its vertices' velocities minus the wind).
  Eigen::Vector3d relative(const VectorX& v, Index t) const;
  /// Triangle t's air force at relative velocity vr (N, the whole triangle's).
  Eigen::Vector3d triangleForce(const Eigen::Vector3d& vr, std::size_t t) const;
  /// d^2 D_t / dv_r^2 / (1/2 rho A_t) at relative velocity vr.
  Eigen::Matrix3d triangleCurvature(const Eigen::Vector3d& vr, std::size_t t) const;
  std::shared_ptr<const Mesh> mesh_;
  AirSettings settings_;
  std::vector<Eigen::Vector3d> normal_;
  std::vector<double> area_;
  VertexIncidence incidence_;  // the triangles of each vertex (prepareVertexAccess)
  // Hessian slots of each triangle's vertex pairs, for the pattern they were taken from.
  std::vector<int> offsets_;
  const SparseHessian* offsetsFor_ = nullptr;
  // Scratch of explicitRate (per vertex), kept so that explicit substeps do not allocate.
  mutable std::vector<double> rowSum_;
};

/// The explicit use of the air force (symplectic Euler, XPBD, projective dynamics): the
/// commanded forces plus the air force at the substep's starting state, and its work.
class LaggedAir {
 public:
  /// Prepares the substep from `state` of length h: forces() is then `external` itself without
  /// air, and external + the air force at state.v with air. False, with report.error (naming
  /// `integrator`) and report.ok set, when h is too long for an explicit drag force
  /// (AirModel::explicitRate); retryable: more substeps help. (`integrator` is a C string: no
  /// allocation in the step loop.)
  bool begin(AirModel* air, const VectorX& external, const State& state, const VectorX& vertexMasses,
             double h, const char* integrator, StepReport& report);
  const VectorX* forces() const { return forces_; }
  /// The air force's work (J) over the substep, from begin()'s positions to xEnd (0 without air).
  double work(const VectorX& xEnd) const;

 private:
  bool active_ = false;
  const VectorX* forces_ = nullptr;
  VectorX airForce_, total_, xStart_;
};

}  // namespace fem_cloth
