// Immutable per-triangle rest data, computed once per mesh.
//
// For each triangle with rest vertices X0, X1, X2:
//  - tangentFrame T (d x 2, orthonormal columns spanning the rest plane). Planar meshes use
//    T = I (2 x 2). Cloth uses t1 = (X1 - X0)/|X1 - X0| and t2 = n x t1, n the unit normal.
//  - Dm = T^T [X1 - X0, X2 - X0] (2 x 2), the rest edge matrix in the rest 2D frame, and its
//    inverse DmInverse. F = Ds * DmInverse is then the identity at rest.
//  - restArea = |det Dm| / 2 (m^2).
//  - shapeGradients G (3 x 2): row a is g_a^T with F = sum_a x_a g_a^T, so that
//    dF/dx_a = (.) g_a^T and, for an energy A*psi(F), the gradient on vertex a is A * P * g_a
//    (Sifakis & Barbic 2012, section 4.2).
#pragma once

#include <vector>

#include "fem_cloth/core/conventions.h"
#include "fem_cloth/core/expected.h"
#include "fem_cloth/core/mesh.h"

namespace fem_cloth {

struct RestState {
  int dim = 3;
  std::vector<Eigen::Matrix2d> DmInverse;
  std::vector<double> restArea;
  /// Rest tangent frame per triangle; for planar meshes the top 2 x 2 block is the identity and
  /// the last row is zero.
  std::vector<Eigen::Matrix<double, 3, 2>> tangentFrame;
  std::vector<Eigen::Matrix<double, 3, 2>> shapeGradients;

  Index numTriangles() const { return static_cast<Index>(restArea.size()); }

  template <int D>
  DefGrad<D> frame(Index t) const {
    return tangentFrame[t].template topRows<D>();
  }
};

/// Precomputes the rest data. Fails (naming the triangle) if a triangle has zero rest area;
/// run validateMesh first for the full report.
Expected<RestState> computeRestState(const Mesh& mesh);

/// Lumped vertex masses (kg): each triangle gives a third of arealDensity * restArea to each of
/// its vertices.
VectorX lumpedMasses(const Mesh& mesh, const RestState& rest, double arealDensity);

/// Deformation gradient of triangle t at the flat positions x: F = Ds * DmInverse.
template <int D>
DefGrad<D> deformationGradient(const Mesh& mesh, const RestState& rest, const VectorX& x,
                               Index t) {
  const Triangle& tri = mesh.triangles[t];
  const auto x0 = x.segment<D>(D * tri[0]);
  Eigen::Matrix<double, D, 2> Ds;
  Ds.col(0) = x.segment<D>(D * tri[1]) - x0;
  Ds.col(1) = x.segment<D>(D * tri[2]) - x0;
  return Ds * rest.DmInverse[t];
}

}  // namespace fem_cloth
