// Linear (small-strain) elasticity: psi = mu eps:eps + lambda/2 (tr eps)^2 with
// eps = sym(F^) - I and F^ = T^T F the deformation gradient seen in the rest tangent frame
// (F^ = F for planar elements). The only model that is not rotation invariant: a rigid rotation
// of the element is strained, and F = [[1, 0.5], [-0.5, 1]], which changes the area, is not.
// Sifakis & Barbic 2012, section 3.2.
#pragma once

#include "fem_cloth/core/materials/material.h"

namespace fem_cloth {

class LinearElasticity : public MaterialBase {
 public:
  static constexpr const char* kName = "linear";
  static constexpr bool kNeedsPolar = false;
  static constexpr bool kRotationInvariant = false;

  explicit LinearElasticity(const Lame& lame) : MaterialBase(lame) {}


  template <int D>
  double psi(const DefGrad<D>& F, const DefGrad<D>& T) const {
    const Eigen::Matrix2d eps = strain(F, T);
    return mu_ * eps.squaredNorm() + 0.5 * lambda_ * eps.trace() * eps.trace();
  }

  template <int D>
  DefGrad<D> pk1(const DefGrad<D>& F, const DefGrad<D>& T) const {
    const Eigen::Matrix2d eps = strain(F, T);
    return T * (2.0 * mu_ * eps + lambda_ * eps.trace() * Eigen::Matrix2d::Identity());
  }

  /// Constant: H[dF] = T (2 mu sym(T^T dF) + lambda tr(T^T dF) I), assembled column by column.
  template <int D>
  StressHessian<D> hessian(const DefGrad<D>& /*F*/, const DefGrad<D>& T) const {
    StressHessian<D> H;
    for (int c = 0; c < 2; ++c) {
      for (int r = 0; r < D; ++r) {
        DefGrad<D> dF = DefGrad<D>::Zero();
        dF(r, c) = 1.0;
        const Eigen::Matrix2d g = T.transpose() * dF;
        const Eigen::Matrix2d s = 0.5 * (g + g.transpose());
        const DefGrad<D> dP =
            T * (2.0 * mu_ * s + lambda_ * g.trace() * Eigen::Matrix2d::Identity());
        H.col(r + D * c) = Eigen::Map<const Eigen::Matrix<double, 2 * D, 1>>(dP.data());
      }
    }
    return H;
  }

  /// PSD already when mu >= 0 and mu + lambda >= 0; the clamp covers other parameter choices.
  template <int D>
  StressHessian<D> projectedHessian(const DefGrad<D>& F, const DefGrad<D>& T) const {
    return clampEigenvalues<D>(hessian<D>(F, T));
  }

  /// Constraint form: C = (eps11, eps22, sqrt2 eps12), linear in F.
  static constexpr int kNumConstraints = 3;
  ConstraintStiffness constraintStiffness() const { return strainStiffness(mu_, lambda_); }
  template <int D>
  bool constraints(const DefGrad<D>& F, const DefGrad<D>& T, ConstraintValues& C,
                   ConstraintJacobian<D>& J) const {
    strainConstraints<D>(
        strain(F, T),
        [&](int j) {
          DefGrad<D> dF = DefGrad<D>::Zero();
          dF.data()[j] = 1.0;
          const Eigen::Matrix2d g = T.transpose() * dF;
          return Eigen::Matrix2d(0.5 * (g + g.transpose()));
        },
        C, J);
    return true;
  }

 private:
  template <int D>
  static Eigen::Matrix2d strain(const DefGrad<D>& F, const DefGrad<D>& T) {
    const Eigen::Matrix2d Fhat = T.transpose() * F;
    return 0.5 * (Fhat + Fhat.transpose()) - Eigen::Matrix2d::Identity();
  }
};

}  // namespace fem_cloth
