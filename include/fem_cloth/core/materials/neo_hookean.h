// Neo-Hookean: psi = mu/2 (I_C - 2) - mu log J + lambda/2 (log J)^2 with I_C = tr(F^T F) and
// J = det F (planar) or |f1 x f2| (cloth). Defined for J > 0 only: psi is +infinity at J <= 0,
// inDomain() says so, and integrators must reject such states (Bonet & Wood; Kim & Eberle 2022,
// section 4).
#pragma once

#include <cmath>
#include <limits>

#include "fem_cloth/core/materials/material.h"

namespace fem_cloth {

class NeoHookean : public IsotropicModel<NeoHookean> {
 public:
  static constexpr const char* kName = "neo_hookean";
  static constexpr bool kNeedsPolar = false;
  static constexpr bool kRotationInvariant = true;

  explicit NeoHookean(const Lame& lame) : IsotropicModel(lame) {}

  template <int D>
  bool inDomain(const DefGrad<D>& F) const {
    return areaRatio(F) > 0.0;
  }

  template <int D>
  double psi(const DefGrad<D>& F, const DefGrad<D>& /*T*/) const {
    const double J = areaRatio(F);
    if (!(J > 0.0)) return std::numeric_limits<double>::infinity();
    const double logJ = std::log(J);
    return 0.5 * mu_ * (F.squaredNorm() - 2.0) - mu_ * logJ + 0.5 * lambda_ * logJ * logJ;
  }

  /// P = mu F + (lambda log J - mu) (dJ/dF) / J; (dJ/dF)/J is F^-T for planar elements.
  template <int D>
  DefGrad<D> pk1(const DefGrad<D>& F, const DefGrad<D>& /*T*/) const {
    const double J = areaRatio(F);
    return mu_ * F + (lambda_ * std::log(J) - mu_) / J * areaRatioGradient(F);
  }

  /// psi_i = mu s_i + c / s_i with c = lambda log J - mu.
  SigmaEigensystem sigmaEigensystem(const Eigen::Vector2d& s, bool cloth) const {
    const double J = s[0] * s[1];
    const double c = lambda_ * std::log(J) - mu_;
    SigmaEigensystem e;
    for (int i = 0; i < 2; ++i) {
      const double inv2 = 1.0 / (s[i] * s[i]);
      e.dpsi[i] = mu_ * s[i] + c / s[i];
      e.d2psi(i, i) = mu_ + (lambda_ - c) * inv2;
      if (cloth) e.outOfPlane[i] = mu_ + c * inv2;
    }
    e.d2psi(0, 1) = e.d2psi(1, 0) = lambda_ / J;
    e.flip = mu_ - c / J;
    e.twist = mu_ + c / J;
    return e;
  }
};

}  // namespace fem_cloth
