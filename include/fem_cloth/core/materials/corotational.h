// Corotational elasticity: psi = mu ||F - R||^2 + lambda/2 (tr(R^T F - I))^2 with R the rotation
// of the polar decomposition F = R S (inversion-aware for planar elements, Irving et al. 2004).
// In signed singular values: psi = mu sum (s_i - 1)^2 + lambda/2 (s1 + s2 - 2)^2.
// Kim & Eberle 2022, section 5; Sifakis & Barbic 2012, section 3.4.
#pragma once

#include "fem_cloth/core/materials/material.h"

namespace fem_cloth {

class Corotational : public IsotropicModel<Corotational> {
 public:
  static constexpr const char* kName = "corotational";
  static constexpr bool kNeedsPolar = true;
  static constexpr bool kRotationInvariant = true;

  explicit Corotational(const Lame& lame) : IsotropicModel(lame) {}


  template <int D>
  double psi(const DefGrad<D>& F, const DefGrad<D>& /*T*/) const {
    const Eigen::Vector2d s = computeSvd<D>(F).sigma;
    const double t = s.sum() - 2.0;
    return mu_ * (s.array() - 1.0).square().sum() + 0.5 * lambda_ * t * t;
  }

  /// P = 2 mu (F - R) + lambda tr(R^T F - I) R.
  template <int D>
  DefGrad<D> pk1(const DefGrad<D>& F, const DefGrad<D>& /*T*/) const {
    const Svd<D> svd = computeSvd<D>(F);
    const DefGrad<D> R = svd.rotation();
    return 2.0 * mu_ * (F - R) + lambda_ * (svd.sigma.sum() - 2.0) * R;
  }

  SigmaEigensystem sigmaEigensystem(const Eigen::Vector2d& s, bool cloth) const {
    const double t = s.sum() - 2.0;
    SigmaEigensystem e;
    for (int i = 0; i < 2; ++i) {
      e.dpsi[i] = 2.0 * mu_ * (s[i] - 1.0) + lambda_ * t;
      if (cloth) e.outOfPlane[i] = e.dpsi[i] / std::max(s[i], kSigmaFloor);
    }
    e.d2psi << 2.0 * mu_ + lambda_, lambda_, lambda_, 2.0 * mu_ + lambda_;
    e.flip = 2.0 * mu_;
    // (psi_1 + psi_2) / (s1 + s2); s1 + s2 >= 0 with the signed SVD, zero only when the
    // element is collapsed or folded onto a line, where R is undefined.
    e.twist = 2.0 * (mu_ + lambda_) * t / std::max(s.sum(), kSigmaFloor);
    return e;
  }

  /// Constraint form: C = (s1 - 1, s2 - 1), K = [[2mu + lambda, lambda], [lambda, 2mu + lambda]].
  static constexpr int kNumConstraints = 2;
  ConstraintStiffness constraintStiffness() const {
    ConstraintStiffness K(2, 2);
    K << 2.0 * mu_ + lambda_, lambda_, lambda_, 2.0 * mu_ + lambda_;
    return K;
  }
  template <int D>
  bool constraints(const DefGrad<D>& F, const DefGrad<D>& /*T*/, ConstraintValues& C,
                   ConstraintJacobian<D>& J) const {
    singularValueConstraints<D>(computeSvd<D>(F), C, J);
    return true;
  }
};

}  // namespace fem_cloth
