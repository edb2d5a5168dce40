// Singular value decompositions of triangle deformation gradients, and the polar decomposition
// built from them.
//
// Planar (2 x 2): the inversion-aware, rotation-variant SVD of Irving, Teran & Fedkiw,
// "Invertible Finite Elements for Robust Simulation of Large Deformation" (2004), section 5:
// F = U diag(s1, s2) V^T with U and V proper rotations (det = +1), s1 >= |s2|, and s2 carrying the
// sign of det F. The rotation R = U V^T therefore stays a rotation when the element inverts.
//
// Cloth (3 x 2): the thin SVD F = U diag(s1, s2) V^T with U (3 x 2) orthonormal columns, V a
// rotation and s1 >= s2 >= 0 (a cloth triangle has no orientation to invert). Computed as F = QR
// (Gram-Schmidt) followed by the 2 x 2 SVD of the upper-triangular R, which stays well defined
// when the triangle collapses. The unit normal of the deformed triangle is u1 x u2.
#pragma once

#include <Eigen/Geometry>

#include "fem_cloth/core/conventions.h"

namespace fem_cloth {

template <int D>
struct Svd {
  Eigen::Matrix<double, D, 2> U;
  Eigen::Vector2d sigma;
  Eigen::Matrix2d V;

  /// R = U V^T: the rotation of the polar decomposition F = R S.
  Eigen::Matrix<double, D, 2> rotation() const { return U * V.transpose(); }
  /// S = V diag(sigma) V^T: the symmetric stretch of F = R S.
  Eigen::Matrix2d stretch() const { return V * sigma.asDiagonal() * V.transpose(); }
};

/// An orthonormal basis Q (3 x 2) of the plane spanned by the columns of F, by Gram-Schmidt from
/// f1, so that Q^T F is upper triangular with a non-negative diagonal (det Q^T F = J >= 0). Any
/// completing vectors are used where F is rank deficient.
Eigen::Matrix<double, 3, 2> planeBasis(const Eigen::Matrix<double, 3, 2>& F);

/// The rotation R (3 x 2, orthonormal columns) of the polar decomposition F = R S of a cloth
/// triangle's F, the same as svd3x2(F).rotation() without the SVD's trigonometry: R = Q r with Q
/// = planeBasis(F) and r the 2 x 2 polar rotation of the upper-triangular Q^T F = [[a, b], [0, d]]
/// (a, d >= 0), whose cosine and sine are (a + d, -b) normalised. The identity's columns in the
/// plane where F = 0.
Eigen::Matrix<double, 3, 2> polarRotation3x2(const Eigen::Matrix<double, 3, 2>& F);

/// Inversion-aware 2 x 2 SVD (closed form, no iteration).
Svd<2> svd2(const Eigen::Matrix2d& F);
/// Thin SVD of a 3 x 2 matrix.
Svd<3> svd3x2(const Eigen::Matrix<double, 3, 2>& F);

template <int D>
Svd<D> computeSvd(const DefGrad<D>& F);
template <>
inline Svd<2> computeSvd<2>(const DefGrad<2>& F) {
  return svd2(F);
}
template <>
inline Svd<3> computeSvd<3>(const DefGrad<3>& F) {
  return svd3x2(F);
}

/// J: det F for planar elements (signed), sqrt(det F^T F) = |f1 x f2| for cloth (>= 0).
inline double areaRatio(const DefGrad<2>& F) { return F.determinant(); }
inline double areaRatio(const DefGrad<3>& F) { return F.col(0).cross(F.col(1)).norm(); }

/// dJ/dF. Planar: the cofactor matrix. Cloth: [f2 x n, n x f1] with n the unit normal; at a
/// collapsed triangle (J = 0), where J is not differentiable, the zero matrix.
inline DefGrad<2> areaRatioGradient(const DefGrad<2>& F) {
  DefGrad<2> cof;
  cof << F(1, 1), -F(1, 0), -F(0, 1), F(0, 0);
  return cof;
}
inline DefGrad<3> areaRatioGradient(const DefGrad<3>& F) {
  const Eigen::Vector3d c = F.col(0).cross(F.col(1));
  const double J = c.norm();
  DefGrad<3> G = DefGrad<3>::Zero();
  if (!(J > 0.0)) return G;
  const Eigen::Vector3d n = c / J;
  G.col(0) = F.col(1).cross(n);
  G.col(1) = n.cross(F.col(0));
  return G;
}

}  // namespace fem_cloth
