// As-rigid-as-possible: psi = mu ||F - R||^2 = mu sum (s_i - 1)^2, with R the rotation of the
// polar decomposition (inversion-aware for planar elements). It has no volume term, so it agrees
// with linear elasticity near rest only for lambda = 0; the lambda it is given is ignored and
// lambda() returns 0. Kim & Eberle 2022, section 5; Smith et al. 2019, section 5.1.
#pragma once

#include "fem_cloth/core/materials/material.h"

namespace fem_cloth {

class Arap : public IsotropicModel<Arap> {
 public:
  static constexpr const char* kName = "arap";
  static constexpr bool kNeedsPolar = true;
  static constexpr bool kRotationInvariant = true;

  explicit Arap(const Lame& lame) : IsotropicModel(Lame{lame.mu, 0.0}) {}


  template <int D>
  double psi(const DefGrad<D>& F, const DefGrad<D>& /*T*/) const {
    if constexpr (D == 3) {
      // |F - R|^2 = |U (Sigma - I) V^T|^2 = sum (s_i - 1)^2, with R without the SVD.
      return mu_ * (F - polarRotation3x2(F)).squaredNorm();
    } else {
      return mu_ * (computeSvd<D>(F).sigma.array() - 1.0).square().sum();
    }
  }

  /// P = 2 mu (F - R).
  template <int D>
  DefGrad<D> pk1(const DefGrad<D>& F, const DefGrad<D>& /*T*/) const {
    return 2.0 * mu_ * (F - rotation<D>(F));
  }

  /// R of the polar decomposition: for cloth without the SVD's trigonometry (svd.h).
  template <int D>
  static DefGrad<D> rotation(const DefGrad<D>& F) {
    if constexpr (D == 3) {
      return polarRotation3x2(F);
    } else {
      return computeSvd<D>(F).rotation();
    }
  }

  SigmaEigensystem sigmaEigensystem(const Eigen::Vector2d& s, bool cloth) const {
    SigmaEigensystem e;
    for (int i = 0; i < 2; ++i) {
      e.dpsi[i] = 2.0 * mu_ * (s[i] - 1.0);
      if (cloth) e.outOfPlane[i] = 2.0 * mu_ * (1.0 - 1.0 / std::max(s[i], kSigmaFloor));
    }
    e.d2psi = 2.0 * mu_ * Eigen::Matrix2d::Identity();
    e.flip = 2.0 * mu_;
    e.twist = 2.0 * mu_ * (1.0 - 2.0 / std::max(s.sum(), kSigmaFloor));
    return e;
  }

  /// Constraint form: C = (s1 - 1, s2 - 1), dC_k/dF = u_k v_k^T, K = 2 mu I.
  static constexpr int kNumConstraints = 2;
  ConstraintStiffness constraintStiffness() const {
    return ConstraintStiffness(2.0 * mu_ * Eigen::Matrix2d::Identity());
  }
  template <int D>
  bool constraints(const DefGrad<D>& F, const DefGrad<D>& /*T*/, ConstraintValues& C,
                   ConstraintJacobian<D>& J) const {
    singularValueConstraints<D>(computeSvd<D>(F), C, J);
    return true;
  }
};

}  // namespace fem_cloth
