// Linear (small-strain) elasticity: psi = mu eps:eps + lambda/2 (tr eps)^2 with
// eps = sym(F^) - I and F^ = T^T F the deformation gradient seen in the rest tangent frame
// (F^ = F for planar elements). The only model that is not rotation invariant: a rigid rotation
// of the element is strained, and F = [[1, 0.5], [-0.5, 1]], which changes the area, is not.
// Sifakis & Barbic 2012, section 3.2.
//
// Validity range: the linear strain is the Green strain E = sym(T^T H) + H^T H / 2 (H = F - T,
// the displacement gradient) without its quadratic part, so the model holds only while H is
// small. Accepted steps keep |H| (spectral norm) <= 0.1 in every element: a rotation of at most
// 0.1 rad (|H| = 2 sin(theta / 2)), whose spurious strain 1 - cos(theta) is at most 0.5 %, and a
// stretch of at most 10 %, where the neglected quadratic part is at most 5 % of the strain. Out of
// its plane the model has no stiffness at all (a cloth folding or falling rotates far beyond it);
// use a rotation-invariant model there.
#pragma once

#include "fem_cloth/core/materials/material.h"

namespace fem_cloth {

class LinearElasticity : public MaterialBase {
 public:
  static constexpr const char* kName = "linear";
  static constexpr bool kNeedsPolar = false;
  static constexpr bool kRotationInvariant = false;

  explicit LinearElasticity(const Lame& lame) : MaterialBase(lame) {}

  static constexpr bool kHasValidityRange = true;
  static constexpr double kValidityLimit = 0.1;
  static constexpr const char* kValidityMeasure = "displacement gradient |F - T| (rotation and stretch)";
  static constexpr const char* kValidityAdvice =
      "the linear membrane holds for small deformations only; use a rotation-invariant model "
      "(corotational, stvk, neo_hookean, ...) for large ones";
  /// |F - T|, the largest singular value of the displacement gradient.
  template <int D>
  double validityMeasure(const DefGrad<D>& F, const DefGrad<D>& T) const {
    const DefGrad<D> H = F - T;
    const Eigen::Matrix2d G = H.transpose() * H;  // symmetric: its largest eigenvalue, closed form
    const double mean = 0.5 * (G(0, 0) + G(1, 1));
    const double half = 0.5 * (G(0, 0) - G(1, 1));
    return std::sqrt(mean + std::sqrt(half * half + G(0, 1) * G(0, 1)));
  }

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
