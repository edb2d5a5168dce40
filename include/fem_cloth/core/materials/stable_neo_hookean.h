// Stable Neo-Hookean (Smith, De Goes & Kim, "Stable Neo-Hookean Flesh Simulation", 2018),
// written for a 2-dimensional reference:
//   psi = mu/2 (I_C - 2) - mu (J - 1) + lambda'/2 (J - 1)^2,   lambda' = lambda + mu.
// This is the paper's mu/2 (I_C - 2) + lambda'/2 (J - alpha)^2 with alpha = 1 + mu/lambda'
// (section 3.4), minus its constant, so psi(I) = 0. In 2D the lambda' = lambda + mu
// reparametrisation (the analogue of the paper's section 3.4 Lame matching) makes the model agree
// with linear elasticity to second order for the given mu and lambda. In singular values,
// psi = mu/2 (s1 - s2)^2 + lambda'/2 (s1 s2 - 1)^2 >= 0. It is finite at collapse (J = 0) and,
// for planar elements, restoring through inversion (J < 0): no log barrier and no singularity.
// The paper's log(I_C + 1) term is left out: in 2D every isotropic energy of (I_C, J) is even in
// F, so F = 0 is stationary whatever is added, and without it psi stays non-negative.
#pragma once

#include "fem_cloth/core/materials/material.h"

namespace fem_cloth {

class StableNeoHookean : public IsotropicModel<StableNeoHookean> {
 public:
  static constexpr const char* kName = "stable_neo_hookean";
  static constexpr bool kNeedsPolar = false;
  static constexpr bool kRotationInvariant = true;

  explicit StableNeoHookean(const Lame& lame)
      : IsotropicModel(lame), lambdaPrime_(lame.lambda + lame.mu) {}


  template <int D>
  double psi(const DefGrad<D>& F, const DefGrad<D>& /*T*/) const {
    const double Jm1 = areaRatio(F) - 1.0;
    return 0.5 * mu_ * (F.squaredNorm() - 2.0) - mu_ * Jm1 + 0.5 * lambdaPrime_ * Jm1 * Jm1;
  }

  /// P = mu F + (lambda' (J - 1) - mu) dJ/dF.
  template <int D>
  DefGrad<D> pk1(const DefGrad<D>& F, const DefGrad<D>& /*T*/) const {
    const double Jm1 = areaRatio(F) - 1.0;
    return mu_ * F + (lambdaPrime_ * Jm1 - mu_) * areaRatioGradient(F);
  }

  SigmaEigensystem sigmaEigensystem(const Eigen::Vector2d& s, bool cloth) const {
    const double J = s[0] * s[1];
    const double k = lambdaPrime_ * (J - 1.0);
    const double d = s[0] - s[1];
    SigmaEigensystem e;
    e.dpsi[0] = mu_ * d + k * s[1];
    e.dpsi[1] = -mu_ * d + k * s[0];
    e.d2psi(0, 0) = mu_ + lambdaPrime_ * s[1] * s[1];
    e.d2psi(1, 1) = mu_ + lambdaPrime_ * s[0] * s[0];
    e.d2psi(0, 1) = e.d2psi(1, 0) = -mu_ + lambdaPrime_ * (2.0 * J - 1.0);
    e.flip = 2.0 * mu_ - k;
    e.twist = k;
    if (cloth) {
      for (int i = 0; i < 2; ++i) e.outOfPlane[i] = e.dpsi[i] / std::max(s[i], kSigmaFloor);
    }
    return e;
  }

  /// Constraint form: with G = Q^T F the deformation seen in an orthonormal basis Q of the
  /// deformed plane (Q = I for planar elements), C = (G11 - G22, G12 + G21, J - 1) and
  /// K = diag(mu, mu, lambda'), since I_C - 2J = (G11 - G22)^2 + (G12 + G21)^2. The first two
  /// are linear in F for planar elements: no SVD. For cloth, dC/dF holds Q fixed, which is exact
  /// at the current F (moving out of the plane changes C only at second order).
  static constexpr int kNumConstraints = 3;
  ConstraintStiffness constraintStiffness() const {
    return ConstraintStiffness(Eigen::Vector3d(mu_, mu_, lambdaPrime_).asDiagonal());
  }
  template <int D>
  bool constraints(const DefGrad<D>& F, const DefGrad<D>& /*T*/, ConstraintValues& C,
                   ConstraintJacobian<D>& J) const {
    DefGrad<D> Q;
    if constexpr (D == 2) {
      Q.setIdentity();
    } else {
      Q = planeBasis(F);
    }
    const Eigen::Matrix2d G = Q.transpose() * F;
    C.resize(3);
    C << G(0, 0) - G(1, 1), G(0, 1) + G(1, 0), areaRatio(F) - 1.0;
    J.resize(3, 2 * D);
    J.row(0) = vecRow<D>(Q.col(0) * Eigen::RowVector2d(1, 0) - Q.col(1) * Eigen::RowVector2d(0, 1));
    J.row(1) = vecRow<D>(Q.col(0) * Eigen::RowVector2d(0, 1) + Q.col(1) * Eigen::RowVector2d(1, 0));
    J.row(2) = vecRow<D>(areaRatioGradient(F));
    return true;
  }

 private:
  double lambdaPrime_;
};

}  // namespace fem_cloth
