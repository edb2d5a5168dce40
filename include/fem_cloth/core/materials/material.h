// The common material interface.
//
// A material is a small class on the deformation gradient F of a triangle (2 x 2 planar,
// 3 x 2 cloth) giving the energy density psi per unit rest area, the first Piola-Kirchhoff stress
// P = d psi / dF, the stress Hessian d^2 psi / dF^2 and a positive semi-definite projection of it
// for Newton's method. Every method takes the rest tangent frame T (d x 2) as well: only the
// linear model uses it (it measures strain as sym(T^T F) - I, the one model that is not rotation
// invariant); for planar meshes T = I.
//
// Members every model has (static polymorphism, see the Material variant below):
//   static constexpr const char* kName;
//   static constexpr bool kNeedsPolar;        // psi and P need an SVD / polar decomposition
//   static constexpr bool kRotationInvariant;
//   double mu() const, lambda() const;          // Lame parameters the model was built with
//   template <int D> bool inDomain(F) const;    // false where psi is undefined (Neo-Hookean, J<=0)
//   template <int D> double psi(F, T) const;    // +infinity outside the domain
//   template <int D> DefGrad<D> pk1(F, T) const;
//   template <int D> StressHessian<D> hessian(F, T) const;
//   template <int D> StressHessian<D> projectedHessian(F, T) const;
// pk1, hessian and projectedHessian must only be called inside the domain.
//
// Optional members, the constraint form XPBD visits (see below; kHasConstraintForm in
// materials.h detects them at compile time, and the integrator registry lets XPBD take only the
// models that have them):
//   static constexpr int kNumConstraints;
//   ConstraintStiffness constraintStiffness() const;
//   template <int D> bool constraints(F, T, ConstraintValues&, ConstraintJacobian<D>&) const;
//
// Constraint form (for XPBD): a model that has one writes its energy exactly as
//   psi(F) = 1/2 C(F)^T K C(F)
// with k <= 3 signed constraint functions C(F), zero at rest, and a constant k x k matrix K.
// Signed matters: a constraint such as sqrt(2 psi) has a cusp at rest, where its gradient flips,
// and XPBD's accumulated multipliers then push the wrong way. constraints() returns false outside
// the domain.
//
// Hessians are computed only when asked; models whose energy is written in invariants of
// C = F^T F (StVK, Neo-Hookean, Stable Neo-Hookean) evaluate psi and P without any SVD.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "fem_cloth/core/conventions.h"
#include "fem_cloth/core/svd.h"

namespace fem_cloth {

/// Lame parameters. Units are those of the energy density: N/m (J/m^2) when psi is per unit rest
/// area of a membrane (fem_cloth's convention: volumetric moduli times thickness), Pa for a
/// volumetric density.
struct Lame {
  double mu = 0.0;
  double lambda = 0.0;

  /// Plane stress (thin sheet): mu = E / (2 (1 + nu)), lambda = E nu / (1 - nu^2).
  static Lame fromYoungPoisson(double youngsModulus, double poissonRatio) {
    return Lame{youngsModulus / (2.0 * (1.0 + poissonRatio)),
                youngsModulus * poissonRatio / (1.0 - poissonRatio * poissonRatio)};
  }
};

/// The derivatives of an isotropic energy written in the signed singular values s = (s1, s2)
/// that determine the eigensystem of its stress Hessian (Smith, De Goes & Kim, "Analytic
/// Eigensystems for Isotropic Distortion Energies", 2019, section 4, written here for a
/// 2-dimensional reference):
///  - scaling modes U diag(a) V^T, a an eigenvector of d2psi (2 x 2);
///  - flip mode  U [[0,1],[1,0]] V^T / sqrt2, eigenvalue (psi_1 - psi_2) / (s1 - s2);
///  - twist mode U [[0,-1],[1,0]] V^T / sqrt2, eigenvalue (psi_1 + psi_2) / (s1 + s2);
///  - cloth only (F is 3 x 2, n = u1 x u2): out-of-plane modes n v_j^T with eigenvalue
///    psi_j / s_j, since moving the triangle along its normal changes s_j only at second order.
/// Each model writes flip, twist and outOfPlane in closed form, so that s1 = s2 and collapsed
/// triangles need no division by zero.
struct SigmaEigensystem {
  Eigen::Vector2d dpsi = Eigen::Vector2d::Zero();
  Eigen::Matrix2d d2psi = Eigen::Matrix2d::Zero();
  double flip = 0.0;
  double twist = 0.0;
  Eigen::Vector2d outOfPlane = Eigen::Vector2d::Zero();
};

/// Assembles sum_k max(l_k, 0) q_k q_k^T (project = true) or sum_k l_k q_k q_k^T (the exact
/// Hessian) from the eigensystem above.
template <int D>
StressHessian<D> isotropicHessian(const Svd<D>& svd, const SigmaEigensystem& eig, bool project);

constexpr int kMaxConstraints = 3;
using ConstraintValues = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxConstraints, 1>;
using ConstraintStiffness =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxConstraints, kMaxConstraints>;
/// dC/dvec(F): k x 2D.
template <int D>
using ConstraintJacobian = Eigen::Matrix<double, Eigen::Dynamic, 2 * D, 0, kMaxConstraints, 2 * D>;

/// Row-vector form of a D x 2 matrix in the vec(F) ordering.
template <int D>
Eigen::Matrix<double, 1, 2 * D> vecRow(const DefGrad<D>& M) {
  return Eigen::Map<const Eigen::Matrix<double, 1, 2 * D>>(M.data());
}

/// The isotropic stiffness [[2mu + lambda, lambda, 0], [lambda, 2mu + lambda, 0], [0, 0, 2mu]]
/// of a symmetric strain written as (e11, e22, sqrt2 e12), so that mu e:e + lambda/2 (tr e)^2 =
/// 1/2 c^T K c.
inline ConstraintStiffness strainStiffness(double mu, double lambda) {
  ConstraintStiffness K(3, 3);
  K << 2 * mu + lambda, lambda, 0, lambda, 2 * mu + lambda, 0, 0, 0, 2 * mu;
  return K;
}

/// Constraints (e11, e22, sqrt2 e12) of a symmetric 2 x 2 strain e and their Jacobian, given
/// the derivative of e along each vec(F) direction (a functor j -> de).
template <int D, class StrainDerivative>
void strainConstraints(const Eigen::Matrix2d& e, StrainDerivative de, ConstraintValues& C,
                       ConstraintJacobian<D>& J) {
  const double r2 = std::sqrt(2.0);
  C.resize(3);
  C << e(0, 0), e(1, 1), r2 * e(0, 1);
  J.resize(3, 2 * D);
  for (int j = 0; j < 2 * D; ++j) {
    const Eigen::Matrix2d d = de(j);
    J(0, j) = d(0, 0);
    J(1, j) = d(1, 1);
    J(2, j) = r2 * 0.5 * (d(0, 1) + d(1, 0));
  }
}

/// C = (s1 - 1, s2 - 1) with dC_k/dF = u_k v_k^T (ARAP, corotational).
template <int D>
void singularValueConstraints(const Svd<D>& svd, ConstraintValues& C, ConstraintJacobian<D>& J) {
  C.resize(2);
  J.resize(2, 2 * D);
  for (int k = 0; k < 2; ++k) {
    C[k] = svd.sigma[k] - 1.0;
    J.row(k) = vecRow<D>(svd.U.col(k) * svd.V.col(k).transpose());
  }
}

/// Numerical PSD projection: eigen-decomposition with negative eigenvalues set to zero.
template <int D>
StressHessian<D> clampEigenvalues(const StressHessian<D>& H);

/// A guard for divisions by singular values of collapsed elements (dimensionless, relative to 1).
constexpr double kSigmaFloor = 1e-12;

/// What every model holds: its Lame parameters. Models are defined everywhere unless they say
/// otherwise (Neo-Hookean hides inDomain with its own).
class MaterialBase {
 public:
  explicit MaterialBase(const Lame& lame) : mu_(lame.mu), lambda_(lame.lambda) {}
  double mu() const { return mu_; }
  double lambda() const { return lambda_; }
  template <int D>
  bool inDomain(const DefGrad<D>& /*F*/) const {
    return true;
  }
  /// Whether the model describes the material only in part of its domain. A model with a range
  /// also has kValidityLimit, kValidityMeasure and kValidityAdvice (for messages) and
  /// validityMeasure<D>(F, T), valid while the measure is at most the limit; the acceptance of
  /// a step checks it (integrators/acceptance.h, test (c)).
  static constexpr bool kHasValidityRange = false;

 protected:
  double mu_;
  double lambda_;
};

/// CRTP base for models that are functions of the singular values: the exact and projected
/// Hessians come from the model's sigmaEigensystem(s, cloth).
template <class Model>
class IsotropicModel : public MaterialBase {
 public:
  using MaterialBase::MaterialBase;

  template <int D>
  StressHessian<D> hessian(const DefGrad<D>& F, const DefGrad<D>& /*restFrame*/) const {
    const Svd<D> svd = computeSvd<D>(F);
    return isotropicHessian<D>(svd, self().sigmaEigensystem(svd.sigma, D == 3), false);
  }
  template <int D>
  StressHessian<D> projectedHessian(const DefGrad<D>& F, const DefGrad<D>& /*restFrame*/) const {
    const Svd<D> svd = computeSvd<D>(F);
    return isotropicHessian<D>(svd, self().sigmaEigensystem(svd.sigma, D == 3), true);
  }

 private:
  const Model& self() const { return static_cast<const Model&>(*this); }
};

}  // namespace fem_cloth
