// St. Venant-Kirchhoff: psi = mu E:E + lambda/2 (tr E)^2 with the Green strain E = (C - I)/2,
// C = F^T F. Rotation invariant, but it softens under compression: under uniaxial compression
// F = diag(1, s) with lambda = 0 the restoring stress P22 = mu (s^2 - 1) s peaks at s = 1/sqrt(3)
// and falls to zero as the element collapses, and an inverted element is pushed further in.
// Sifakis & Barbic 2012, section 3.3; Kim & Eberle 2022, section 3.
#pragma once

#include "fem_cloth/core/materials/material.h"

namespace fem_cloth {

class StVenantKirchhoff : public IsotropicModel<StVenantKirchhoff> {
 public:
  static constexpr const char* kName = "stvk";
  static constexpr bool kNeedsPolar = false;
  static constexpr bool kRotationInvariant = true;

  explicit StVenantKirchhoff(const Lame& lame) : IsotropicModel(lame) {}


  template <int D>
  double psi(const DefGrad<D>& F, const DefGrad<D>& /*T*/) const {
    const Eigen::Matrix2d E = greenStrain(F);
    return mu_ * E.squaredNorm() + 0.5 * lambda_ * E.trace() * E.trace();
  }

  /// P = F S with the second Piola-Kirchhoff stress S = 2 mu E + lambda tr(E) I.
  template <int D>
  DefGrad<D> pk1(const DefGrad<D>& F, const DefGrad<D>& /*T*/) const {
    const Eigen::Matrix2d E = greenStrain(F);
    return F * (2.0 * mu_ * E + lambda_ * E.trace() * Eigen::Matrix2d::Identity());
  }

  /// psi = mu/4 sum (s_i^2 - 1)^2 + lambda/8 (s1^2 + s2^2 - 2)^2.
  SigmaEigensystem sigmaEigensystem(const Eigen::Vector2d& s, bool cloth) const {
    const double ic = s.squaredNorm();
    const double volumetric = 0.5 * lambda_ * (ic - 2.0);
    SigmaEigensystem e;
    for (int i = 0; i < 2; ++i) {
      e.dpsi[i] = mu_ * (s[i] * s[i] - 1.0) * s[i] + volumetric * s[i];
      e.d2psi(i, i) = mu_ * (3.0 * s[i] * s[i] - 1.0) + volumetric + lambda_ * s[i] * s[i];
      if (cloth) e.outOfPlane[i] = mu_ * (s[i] * s[i] - 1.0) + volumetric;
    }
    e.d2psi(0, 1) = e.d2psi(1, 0) = lambda_ * s[0] * s[1];
    e.flip = mu_ * (s[0] * s[0] + s[0] * s[1] + s[1] * s[1] - 1.0) + volumetric;
    e.twist = mu_ * (s[0] * s[0] - s[0] * s[1] + s[1] * s[1] - 1.0) + volumetric;
    return e;
  }

  /// Constraint form: C = (E11, E22, sqrt2 E12) of the Green strain.
  static constexpr int kNumConstraints = 3;
  ConstraintStiffness constraintStiffness() const { return strainStiffness(mu_, lambda_); }
  template <int D>
  bool constraints(const DefGrad<D>& F, const DefGrad<D>& /*T*/, ConstraintValues& C,
                   ConstraintJacobian<D>& J) const {
    strainConstraints<D>(
        greenStrain(F),
        [&](int j) {
          DefGrad<D> dF = DefGrad<D>::Zero();
          dF.data()[j] = 1.0;
          const Eigen::Matrix2d g = dF.transpose() * F;
          return Eigen::Matrix2d(0.5 * (g + g.transpose()));
        },
        C, J);
    return true;
  }

 private:
  template <int D>
  static Eigen::Matrix2d greenStrain(const DefGrad<D>& F) {
    return 0.5 * (F.transpose() * F - Eigen::Matrix2d::Identity());
  }
};

}  // namespace fem_cloth
