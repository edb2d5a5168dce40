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

 private:
  double lambdaPrime_;
};

}  // namespace fem_cloth
