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

  /// Constraint form: C = (g(s1), g(s2), log J) with g(s) = sign(s - 1) sqrt(s^2 - 1 - 2 log s),
  /// K = diag(mu, mu, lambda): psi = mu/2 sum (s_k^2 - 1 - 2 log s_k) + lambda/2 (log J)^2.
  static constexpr int kNumConstraints = 3;
  ConstraintStiffness constraintStiffness() const {
    return ConstraintStiffness(Eigen::Vector3d(mu_, mu_, lambda_).asDiagonal());
  }
  template <int D>
  bool constraints(const DefGrad<D>& F, const DefGrad<D>& /*T*/, ConstraintValues& C,
                   ConstraintJacobian<D>& J) const {
    const Svd<D> svd = computeSvd<D>(F);
    if (!(svd.sigma[0] > 0.0 && svd.sigma[1] > 0.0)) return false;
    C.resize(3);
    J.resize(3, 2 * D);
    for (int k = 0; k < 2; ++k) {
      double g = 0.0, dg = 0.0;
      deviation(svd.sigma[k], g, dg);
      C[k] = g;
      J.row(k) = dg * vecRow<D>(svd.U.col(k) * svd.V.col(k).transpose());
    }
    C[2] = std::log(svd.sigma[0] * svd.sigma[1]);
    J.row(2) = vecRow<D>(svd.U * svd.sigma.cwiseInverse().asDiagonal() * svd.V.transpose());
    return true;
  }

 private:
  /// g(s) = sign(s - 1) sqrt(s^2 - 1 - 2 log s) and g'(s) = (s - 1/s) / g(s); near s = 1 from
  /// the series s^2 - 1 - 2 log s = 2t^2 (1 - t/3 + t^2/4 - t^3/5), t = s - 1.
  static void deviation(double s, double& g, double& dg) {
    const double t = s - 1.0;
    if (std::abs(t) < 1e-3) {
      const double q = std::sqrt(1.0 - t / 3.0 + t * t / 4.0 - t * t * t / 5.0);
      g = std::sqrt(2.0) * t * q;
      dg = (2.0 + t) / ((1.0 + t) * std::sqrt(2.0) * q);
      return;
    }
    const double f = t * (2.0 + t) - 2.0 * std::log1p(t);
    g = (t > 0.0 ? 1.0 : -1.0) * std::sqrt(std::max(f, 0.0));
    dg = (s - 1.0 / s) / g;
  }
};

}  // namespace fem_cloth
