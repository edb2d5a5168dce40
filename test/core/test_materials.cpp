// The six material models, each for planar (D = 2, F 2 x 2, T = I) and cloth (D = 3, F 3 x 2,
// T an orthonormal 3 x 2 rest frame) elements. Expected values come from closed forms written in
// this file (the small-strain energy, hand-derived stresses along F = diag(1, s)), from central
// finite differences, and from an eigen-decomposition done here; never from the models themselves.
//
// Sign convention used throughout: along F = diag(1, s) (in the rest frame), dF/ds = e2 e2^T, so
// d psi / ds = P : e2 e2^T = P22 and the generalised force on s is -P22. A stress is restoring
// under compression (s < 1) when it pushes s up: P22 < 0.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "fem_cloth/core/materials/materials.h"
#include "random_matrices.h"

using namespace fem_cloth;
using test_support::clothRestFrames;
using test_support::RandomMatrices;

namespace {

// Lame parameters for the tests (N/m): arbitrary, positive, mu != lambda so that a swapped
// parameter shows.
constexpr double kMu = 1.3;
constexpr double kLambda = 2.1;

template <class Model>
Model makeModel(double mu = kMu, double lambda = kLambda) {
  return Model(Lame{mu, lambda});
}

template <class Model>
constexpr bool kIsNeoHookean = std::is_same_v<Model, NeoHookean>;

/// The lambda of the small-strain energy a model matches near rest: ARAP has no volume term.
template <class Model>
constexpr double linearEquivalentLambda() {
  return std::is_same_v<Model, Arap> ? 0.0 : kLambda;
}

/// Small-strain energy, written out here (Sifakis & Barbic 2012, section 3.2):
/// eps = sym(T^T F) - I, psi = mu eps:eps + lambda/2 (tr eps)^2.
template <int D>
double smallStrainEnergy(const DefGrad<D>& F, const DefGrad<D>& T, double mu, double lambda) {
  const Eigen::Matrix2d G = T.transpose() * F;
  const Eigen::Matrix2d eps = 0.5 * (G + G.transpose()) - Eigen::Matrix2d::Identity();
  return mu * eps.squaredNorm() + 0.5 * lambda * eps.trace() * eps.trace();
}

/// J computed here: det F (planar), |f1 x f2| (cloth).
double areaOf(const DefGrad<2>& F) { return F(0, 0) * F(1, 1) - F(0, 1) * F(1, 0); }
double areaOf(const DefGrad<3>& F) { return F.col(0).cross(F.col(1)).norm(); }

DefGrad<2> planarIdentity() { return DefGrad<2>::Identity(); }

Eigen::Matrix2d diag(double a, double b) { return Eigen::Vector2d(a, b).asDiagonal(); }

template <int D>
Eigen::Matrix<double, 2 * D, 1> vec(const DefGrad<D>& M) {
  return Eigen::Map<const Eigen::Matrix<double, 2 * D, 1>>(M.data());
}

/// Rest frames: the identity for planar elements, several orthonormal 3 x 2 frames for cloth.
template <int D>
std::vector<DefGrad<D>> restFrames() {
  if constexpr (D == 2) {
    return {planarIdentity()};
  } else {
    return clothRestFrames(101);
  }
}

/// A random deformation gradient around the rest frame: in-plane part T (I + a A) plus, for
/// cloth, an out-of-plane part n b^T.
template <int D>
DefGrad<D> randomDeformation(RandomMatrices& random, const DefGrad<D>& T, double a) {
  DefGrad<D> F = T * (Eigen::Matrix2d::Identity() + a * random.matrix<2, 2>());
  if constexpr (D == 3) {
    const Eigen::Vector3d n = T.col(0).cross(T.col(1));
    F += a * n * random.matrix<1, 2>();
  }
  return F;
}

/// Max-norm errors of central differences of f (a function of F with Rows values) against the
/// analytic derivative (column i = d f / d vec(F)_i), one per step.
template <int D, int Rows, class Function>
std::vector<double> centralDifferenceErrors(const Function& f, const DefGrad<D>& F,
                                            const Eigen::Matrix<double, Rows, 2 * D>& analytic,
                                            const std::vector<double>& steps) {
  std::vector<double> errors;
  for (double h : steps) {
    double error = 0.0;
    for (int i = 0; i < 2 * D; ++i) {
      DefGrad<D> Fp = F, Fm = F;
      Fp.data()[i] += h;
      Fm.data()[i] -= h;
      const Eigen::Matrix<double, Rows, 1> fd = (f(Fp) - f(Fm)) / (2.0 * h);
      error = std::max(error, (fd - analytic.col(i)).cwiseAbs().maxCoeff());
    }
    errors.push_back(error);
  }
  return errors;
}

/// psi and vec(P) as functions of F, for the difference checks.
template <class Model, int D>
auto energyFunction(const Model& model, const DefGrad<D>& T) {
  return [&model, T](const DefGrad<D>& F) {
    return Eigen::Matrix<double, 1, 1>(model.template psi<D>(F, T));
  };
}
template <class Model, int D>
auto stressFunction(const Model& model, const DefGrad<D>& T) {
  return [&model, T](const DefGrad<D>& F) { return vec<D>(model.template pk1<D>(F, T)); };
}

/// The central-difference error falls like h^2 until round-off (relative floor) takes over; for
/// quadratic energies it is at round-off for every step.
void expectErrorsFall(const std::vector<double>& errors, double scale, const std::string& what) {
  const double floor = 1e-9 * scale;
  EXPECT_LT(*std::min_element(errors.begin(), errors.end()), 1e-7 * scale) << what;
  for (std::size_t k = 0; k + 1 < errors.size(); ++k) {
    if (errors[k] > floor) {
      EXPECT_LT(errors[k + 1], std::max(0.05 * errors[k], floor))
          << what << ": error does not fall like h^2 from step " << k;
    }
  }
}

const std::vector<double> kSteps = {1e-2, 1e-3, 1e-4};

/// Numerical PSD projection done here: eigen-decomposition, negative eigenvalues set to zero.
template <int D>
StressHessian<D> clampedHere(const StressHessian<D>& H) {
  Eigen::SelfAdjointEigenSolver<StressHessian<D>> eig(0.5 * (H + H.transpose()));
  return eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() *
         eig.eigenvectors().transpose();
}

/// Points where analytic eigensystems are easy to get wrong: s1 = s2 (rest, uniform stretch and
/// compression, rotated), s1 - s2 tiny, near-collapse, and (planar) inverted elements. Written as
/// 2 x 2 in-plane deformations A; cloth uses T A (and inversions are left out: a cloth triangle has
/// no orientation). hardPointNames[k] names A[k].
const std::vector<std::string> kHardPointNames = {
    "rest",          "s1 = s2 > 1",         "s1 = s2 < 1, rotated", "s1 - s2 = 1e-9",
    "near collapse", "collapsing, rotated", "inverted",             "inverted, rotated",
    "inverted, s1 = -s2 + 0.2"};

std::vector<Eigen::Matrix2d> hardPoints() {
  const Eigen::Matrix2d R = Eigen::Rotation2Dd(0.7).toRotationMatrix();
  const Eigen::Matrix2d Rv = Eigen::Rotation2Dd(-1.1).toRotationMatrix();
  return {Eigen::Matrix2d::Identity(),
          1.3 * Eigen::Matrix2d::Identity(),
          0.7 * R,
          R * diag(1.2, 1.2 - 1e-9) * Rv.transpose(),
          diag(1.0, 1e-2),
          R * diag(0.9, 0.02) * Rv.transpose(),
          diag(1.0, -0.5),
          R * diag(1.1, -0.3) * Rv.transpose(),
          diag(0.8, -0.6)};
}

bool isInverted(const Eigen::Matrix2d& A) { return A.determinant() < 0.0; }

}  // namespace

// ---------------------------------------------------------------------------------------------
// Properties every model must have, checked model by model for D = 2 and D = 3.
// ---------------------------------------------------------------------------------------------

template <class Model>
class MaterialModel : public ::testing::Test {};

using AllModels = ::testing::Types<LinearElasticity, StVenantKirchhoff, Corotational, Arap,
                                   NeoHookean, StableNeoHookean>;
class ModelNames {
 public:
  template <class Model>
  static std::string GetName(int) {
    return Model::kName;
  }
};
TYPED_TEST_SUITE(MaterialModel, AllModels, ModelNames);

template <class Model, int D>
void checkRestIsStressFree(const Model& model) {
  for (const DefGrad<D>& T : restFrames<D>()) {
    EXPECT_NEAR(model.template psi<D>(T, T), 0.0, 1e-14) << "D = " << D << ", T =\n" << T;
    EXPECT_LT(model.template pk1<D>(T, T).cwiseAbs().maxCoeff(), 1e-13) << "D = " << D;
  }
}

TYPED_TEST(MaterialModel, ZeroEnergyAndStressAtRest) {
  const TypeParam model = makeModel<TypeParam>();
  checkRestIsStressFree<TypeParam, 2>(model);
  checkRestIsStressFree<TypeParam, 3>(model);
}

template <class Model, int D>
void checkNonNegative(const Model& model) {
  RandomMatrices random(200 + D);
  int checked = 0;
  for (const DefGrad<D>& T : restFrames<D>()) {
    for (int k = 0; k < 400; ++k) {
      // Wide samples: stretched, compressed, sheared, and (planar) inverted.
      const DefGrad<D> F = random.matrix<D, 2>(-1.5, 1.5);
      if (kIsNeoHookean<Model> && !(areaOf(F) > 0.0)) continue;
      const double psi = model.template psi<D>(F, T);
      ASSERT_TRUE(std::isfinite(psi)) << F;
      EXPECT_GE(psi, -1e-12 * (1.0 + F.squaredNorm())) << "D = " << D << ", F =\n" << F;
      ++checked;
    }
  }
  EXPECT_GT(checked, 150);
}

TYPED_TEST(MaterialModel, NonNegativeOnRandomDeformations) {
  const TypeParam model = makeModel<TypeParam>();
  checkNonNegative<TypeParam, 2>(model);
  checkNonNegative<TypeParam, 3>(model);
}

template <class Model, int D>
void checkRotationInvariance(const Model& model) {
  using WorldRotation = Eigen::Matrix<double, D, D>;
  RandomMatrices random(300 + D);
  for (const DefGrad<D>& T : restFrames<D>()) {
    for (int k = 0; k < 50; ++k) {
      const DefGrad<D> F = randomDeformation<D>(random, T, 0.4);
      WorldRotation Q;
      if constexpr (D == 2) {
        Q = random.rotation2();
      } else {
        Q = random.rotation3();
      }
      const Eigen::Matrix2d Q2 = random.rotation2();
      const double psi = model.template psi<D>(F, T);
      const DefGrad<D> P = model.template pk1<D>(F, T);
      const double tol = 1e-12 * (1.0 + std::abs(psi));
      // Frame indifference: psi(Q F) = psi(F) and the stress turns with the element, P(QF) = Q P.
      const DefGrad<D> QF = Q * F;
      EXPECT_NEAR(model.template psi<D>(QF, T), psi, tol) << "D = " << D;
      EXPECT_LT((model.template pk1<D>(QF, T) - Q * P).cwiseAbs().maxCoeff(), 1e-11) << "D = " << D;
      // Isotropy: rotating the rest configuration changes nothing, P(F Q2) = P(F) Q2.
      const DefGrad<D> FQ = F * Q2;
      EXPECT_NEAR(model.template psi<D>(FQ, T), psi, tol) << "D = " << D;
      EXPECT_LT((model.template pk1<D>(FQ, T) - P * Q2).cwiseAbs().maxCoeff(), 1e-11)
          << "D = " << D;
    }
  }
}

/// A rigid rotation by theta in the element's plane: sym(T^T F) - I = (cos theta - 1) I, so the
/// small-strain energy is mu 2 (c - 1)^2 + lambda/2 (2 (c - 1))^2 = 2 (mu + lambda) (c - 1)^2.
template <int D>
void checkLinearSeesRotationAsStrain(const LinearElasticity& model) {
  const double theta = 0.6;
  const double expected = 2.0 * (kMu + kLambda) * std::pow(std::cos(theta) - 1.0, 2);
  for (const DefGrad<D>& T : restFrames<D>()) {
    DefGrad<D> F;
    if constexpr (D == 2) {
      F = Eigen::Rotation2Dd(theta).toRotationMatrix();
    } else {
      const Eigen::Vector3d n = T.col(0).cross(T.col(1));
      F = Eigen::AngleAxisd(theta, n).toRotationMatrix() * T;
    }
    EXPECT_GT(expected, 1e-2);
    EXPECT_NEAR(model.psi<D>(F, T), expected, 1e-13) << "D = " << D;
  }
}

TYPED_TEST(MaterialModel, RotationInvariantExceptLinear) {
  const TypeParam model = makeModel<TypeParam>();
  if constexpr (std::is_same_v<TypeParam, LinearElasticity>) {
    EXPECT_FALSE(TypeParam::kRotationInvariant);
    checkLinearSeesRotationAsStrain<2>(model);
    checkLinearSeesRotationAsStrain<3>(model);
  } else {
    EXPECT_TRUE(TypeParam::kRotationInvariant);
    checkRotationInvariance<TypeParam, 2>(model);
    checkRotationInvariance<TypeParam, 3>(model);
  }
}

/// d(eps) = psi(F) - psi_linear(F) at F = T (I + eps H) (plus eps n b^T out of the plane for
/// cloth, which the small-strain energy ignores and the others feel through C at order eps^2, so
/// in psi at order eps^3). Agreement to second order means d = c3 eps^3 + c4 eps^4 + ...: shrinking
/// eps by 10 divides |d| by about 1000. For some directions c3 is small against c4 eps, and at
/// eps = 1e-2 the two even cancel; so d is split into its odd part (d(eps) - d(-eps))/2 =
/// c3 eps^3 + c5 eps^5, which must fall by 1000, and its even part c2 eps^2 + c4 eps^4, which must
/// fall by 10^4 (no eps^2 term). The linear model itself must match the formula exactly.
template <class Model, int D>
void checkAgreesWithLinearNearRest(const Model& model) {
  RandomMatrices random(400 + D);
  const double lambda = linearEquivalentLambda<Model>();
  for (const DefGrad<D>& T : restFrames<D>()) {
    for (int k = 0; k < 5; ++k) {
      // Unit-size directions, so that the eps^4 terms stand well above round-off.
      const Eigen::Matrix2d H = random.matrix<2, 2>().normalized();
      Eigen::Matrix<double, 1, 2> b = Eigen::Matrix<double, 1, 2>::Zero();
      if (D == 3 && k % 2 == 1) b = random.matrix<1, 2>().normalized();
      const auto difference = [&](double eps) {
        DefGrad<D> F = T * (Eigen::Matrix2d::Identity() + eps * H);
        if constexpr (D == 3) F += eps * T.col(0).cross(T.col(1)) * b;
        const double linear = smallStrainEnergy<D>(F, T, kMu, lambda);
        EXPECT_GT(linear, 0.0);
        return model.template psi<D>(F, T) - linear;
      };
      std::vector<double> odd, even;
      for (double eps : {1e-2, 1e-3}) {
        odd.push_back(0.5 * (difference(eps) - difference(-eps)));
        even.push_back(0.5 * (difference(eps) + difference(-eps)));
      }
      const std::string what = "D = " + std::to_string(D) + ", k = " + std::to_string(k);
      if constexpr (std::is_same_v<Model, LinearElasticity>) {
        EXPECT_LT(std::abs(difference(1e-2)), 1e-15) << what;
        EXPECT_LT(std::abs(difference(1e-3)), 1e-17) << what;
      } else {
        EXPECT_NEAR(odd[0] / odd[1], 1000.0, 50.0) << what << ", H =\n" << H;
        EXPECT_NEAR(even[0] / even[1], 1.0e4, 1.0e3) << what << ", H =\n" << H;
      }
    }
  }
}

TYPED_TEST(MaterialModel, AgreesWithLinearElasticityToSecondOrder) {
  const TypeParam model = makeModel<TypeParam>();
  checkAgreesWithLinearNearRest<TypeParam, 2>(model);
  checkAgreesWithLinearNearRest<TypeParam, 3>(model);
}

template <class Model, int D>
void checkDerivativesAgainstDifferences(const Model& model) {
  RandomMatrices random(500 + D);
  for (const DefGrad<D>& T : restFrames<D>()) {
    for (int k = 0; k < 6; ++k) {
      const DefGrad<D> F = randomDeformation<D>(random, T, 0.5);
      // Stay away from collapse (J = 0), where the large steps would cross a singularity.
      if (std::abs(areaOf(F)) < 0.2) continue;
      const DefGrad<D> P = model.template pk1<D>(F, T);
      const StressHessian<D> H = model.template hessian<D>(F, T);
      const Eigen::Matrix<double, 1, 2 * D> dpsi = vec<D>(P).transpose();
      expectErrorsFall(
          centralDifferenceErrors<D, 1>(energyFunction<Model, D>(model, T), F, dpsi, kSteps),
          1.0 + P.cwiseAbs().maxCoeff(), "P vs FD of psi, D = " + std::to_string(D));
      expectErrorsFall(
          centralDifferenceErrors<D, 2 * D>(stressFunction<Model, D>(model, T), F, H, kSteps),
          1.0 + H.cwiseAbs().maxCoeff(), "dP/dF vs FD of P, D = " + std::to_string(D));
    }
  }
}

TYPED_TEST(MaterialModel, DerivativesMatchCentralDifferences) {
  const TypeParam model = makeModel<TypeParam>();
  checkDerivativesAgainstDifferences<TypeParam, 2>(model);
  checkDerivativesAgainstDifferences<TypeParam, 3>(model);
}

/// At each hard point: the exact Hessian against central differences of P (one small step), and
/// the projected Hessian PSD and equal to the numerical eigenvalue clamp of the exact one.
template <class Model, int D>
void checkHessiansAtHardPoints(const Model& model) {
  const std::vector<Eigen::Matrix2d> points = hardPoints();
  for (const DefGrad<D>& T : restFrames<D>()) {
    for (std::size_t k = 0; k < points.size(); ++k) {
      const bool inverted = isInverted(points[k]);
      if (inverted && (D == 3 || kIsNeoHookean<Model>)) continue;
      const DefGrad<D> F = T * points[k];
      const std::string what = std::string(Model::kName) + ", D = " + std::to_string(D) + ", " +
                               kHardPointNames[k];
      const StressHessian<D> H = model.template hessian<D>(F, T);
      const StressHessian<D> projected = model.template projectedHessian<D>(F, T);
      ASSERT_TRUE(H.allFinite() && projected.allFinite()) << what;
      const double scale = 1.0 + H.cwiseAbs().maxCoeff();
      const double fdError =
          centralDifferenceErrors<D, 2 * D>(stressFunction<Model, D>(model, T), F, H, {1e-7})[0];
      EXPECT_LT(fdError, 1e-5 * scale) << what << "\nH =\n" << H;
      EXPECT_LT((H - H.transpose()).cwiseAbs().maxCoeff(), 1e-12 * scale) << what;
      Eigen::SelfAdjointEigenSolver<StressHessian<D>> eig(projected);
      EXPECT_GT(eig.eigenvalues().minCoeff(), -1e-10 * scale) << what;
      EXPECT_LT((projected - clampedHere<D>(H)).cwiseAbs().maxCoeff(), 1e-10 * scale)
          << what << "\nprojected =\n" << projected << "\nclamped =\n" << clampedHere<D>(H);
      EXPECT_LT((clampEigenvalues<D>(H) - clampedHere<D>(H)).cwiseAbs().maxCoeff(), 1e-10 * scale)
          << what;
    }
  }
}

TYPED_TEST(MaterialModel, ProjectedHessianIsTheEigenvalueClampAtHardPoints) {
  const TypeParam model = makeModel<TypeParam>();
  checkHessiansAtHardPoints<TypeParam, 2>(model);
  checkHessiansAtHardPoints<TypeParam, 3>(model);
}

TYPED_TEST(MaterialModel, ProjectedHessianIsPsdOnRandomDeformations) {
  const TypeParam model = makeModel<TypeParam>();
  RandomMatrices random(600);
  for (int k = 0; k < 300; ++k) {
    const DefGrad<2> F2 = random.matrix<2, 2>(-1.5, 1.5);
    const DefGrad<3> F3 = random.matrix<3, 2>(-1.5, 1.5);
    const DefGrad<3> T = random.restFrame();
    if (!kIsNeoHookean<TypeParam> || areaOf(F2) > 1e-3) {
      const StressHessian<2> exact = model.template hessian<2>(F2, planarIdentity());
      const StressHessian<2> H = model.template projectedHessian<2>(F2, planarIdentity());
      EXPECT_LT((H - clampedHere<2>(exact)).cwiseAbs().maxCoeff(), 1e-9 * (1.0 + exact.norm()))
          << F2;
    }
    if (!kIsNeoHookean<TypeParam> || areaOf(F3) > 1e-3) {
      const StressHessian<3> exact = model.template hessian<3>(F3, T);
      const StressHessian<3> H = model.template projectedHessian<3>(F3, T);
      EXPECT_LT((H - clampedHere<3>(exact)).cwiseAbs().maxCoeff(), 1e-9 * (1.0 + exact.norm()))
          << F3;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// The classic observations that tell the models apart.
// ---------------------------------------------------------------------------------------------

TEST(LinearElasticity, SeesNoStrainInAnAreaChangingRotation) {
  // F = [[1, 0.5], [-0.5, 1]] is a rotation by atan(0.5) scaled by sqrt(1.25): sym(F) = I, so the
  // small-strain measure is zero although the area grows by det F = 1.25.
  Eigen::Matrix2d A;
  A << 1.0, 0.5, -0.5, 1.0;
  EXPECT_DOUBLE_EQ(A(0, 0) * A(1, 1) - A(0, 1) * A(1, 0), 1.25);
  const LinearElasticity linear = makeModel<LinearElasticity>();
  for (const DefGrad<3>& T : restFrames<3>()) {
    EXPECT_NEAR(linear.psi<3>(T * A, T), 0.0, 1e-15);
    EXPECT_LT(linear.pk1<3>(T * A, T).cwiseAbs().maxCoeff(), 1e-14);
  }
  EXPECT_EQ(linear.psi<2>(A, planarIdentity()), 0.0);
  EXPECT_TRUE(linear.pk1<2>(A, planarIdentity()).isZero(0.0));
  // StVK sees it: C = F^T F = 1.25 I, E = 0.125 I, psi = mu 2 (0.125)^2 + lambda/2 (0.25)^2.
  const StVenantKirchhoff stvk = makeModel<StVenantKirchhoff>();
  EXPECT_NEAR(stvk.psi<2>(A, planarIdentity()), 0.03125 * kMu + 0.03125 * kLambda, 1e-15);
}

/// P22 at F = diag(1, s), the restoring stress of uniaxial loading (see the sign convention at
/// the top of the file).
template <class Model>
double uniaxialStress(const Model& model, double s) {
  return model.template pk1<2>(diag(1.0, s), planarIdentity())(1, 1);
}

template <class Model>
double uniaxialEnergy(const Model& model, double s) {
  return model.template psi<2>(diag(1.0, s), planarIdentity());
}

TEST(StVenantKirchhoff, UniaxialRestoringStressPeaksAtOneOverSqrtThree) {
  // With lambda = 0, psi = mu/4 (s^2 - 1)^2 along F = diag(1, s), so P22 = mu (s^2 - 1) s and
  // |P22| = mu s (1 - s^2) on (0, 1), largest where 1 - 3 s^2 = 0.
  const StVenantKirchhoff stvk = makeModel<StVenantKirchhoff>(kMu, 0.0);
  for (double s : {0.2, 0.5, 0.9, -0.4}) {
    EXPECT_NEAR(uniaxialStress(stvk, s), kMu * (s * s - 1.0) * s, 1e-14) << s;
    // The sign convention: P22 is d psi / ds.
    const double h = 1e-6;
    const double slope = (uniaxialEnergy(stvk, s + h) - uniaxialEnergy(stvk, s - h)) / (2 * h);
    EXPECT_NEAR(uniaxialStress(stvk, s), slope, 1e-8) << s;
  }
  // Golden-section search for the maximum of |P22| over (0, 1), on the model's own stress.
  const auto restoring = [&](double s) { return std::abs(uniaxialStress(stvk, s)); };
  const double golden = 0.5 * (std::sqrt(5.0) - 1.0);
  double lo = 0.0, hi = 1.0;
  while (hi - lo > 1e-10) {
    const double a = hi - golden * (hi - lo), b = lo + golden * (hi - lo);
    if (restoring(a) < restoring(b)) lo = a; else hi = b;
  }
  const double peak = 0.5 * (lo + hi);
  EXPECT_NEAR(peak, 1.0 / std::sqrt(3.0), 1e-6);
  EXPECT_NEAR(peak, 0.57735, 1e-5);
  // On a fine grid, the restoring stress rises from rest to the peak and weakens beyond it,
  // vanishing as the element collapses.
  double previous = restoring(1.0);
  EXPECT_EQ(previous, 0.0);
  for (double s = 0.999; s > 0.0; s -= 0.001) {
    const double current = restoring(s);
    EXPECT_LT(uniaxialStress(stvk, s), 0.0) << "not restoring at s = " << s;
    if (s > peak + 1e-3) {
      EXPECT_GT(current, previous) << s;
    } else if (s < peak - 1e-3) {
      EXPECT_LT(current, previous) << s;
    }
    previous = current;
  }
  EXPECT_LT(restoring(1e-3), 1e-2 * restoring(peak));
}

TEST(StVenantKirchhoff, InvertedElementIsPushedFurtherIn) {
  // For s in (-1, 0), P22 = mu (s^2 - 1) s > 0: the force -P22 drives s further negative, and the
  // energy mu/4 (s^2 - 1)^2 indeed falls as s moves towards -1.
  const StVenantKirchhoff stvk = makeModel<StVenantKirchhoff>(kMu, 0.0);
  for (double s = -0.9; s < 0.0; s += 0.1) {
    EXPECT_GT(uniaxialStress(stvk, s), 0.0) << s;
    EXPECT_LT(uniaxialEnergy(stvk, s - 0.01), uniaxialEnergy(stvk, s)) << s;
  }
}

TEST(StableNeoHookean, RestoringThroughCollapseAndInversion) {
  // Along F = diag(1, s): I_C = 1 + s^2, J = s, so psi = mu/2 (s^2 - 1) - mu (s - 1)
  // + lambda'/2 (s - 1)^2 = (mu + lambda')/2 (s - 1)^2 with lambda' = lambda + mu, and
  // P22 = (2 mu + lambda) (s - 1) < 0 for every s < 1: finite and restoring at collapse (s = 0)
  // and through inversion.
  const StableNeoHookean snh = makeModel<StableNeoHookean>();
  const double k = 2.0 * kMu + kLambda;
  for (double s = -1.0; s < 0.95; s += 0.05) {
    EXPECT_NEAR(uniaxialEnergy(snh, s), 0.5 * k * (s - 1.0) * (s - 1.0), 1e-13) << s;
    EXPECT_NEAR(uniaxialStress(snh, s), k * (s - 1.0), 1e-13) << s;
    EXPECT_LT(uniaxialStress(snh, s), 0.0) << s;
  }
  EXPECT_NEAR(uniaxialEnergy(snh, 0.0), 0.5 * k, 1e-15);
  EXPECT_NEAR(uniaxialStress(snh, 0.0), -k, 1e-15);
  // Where StVK pushes an inverted element further in, Stable Neo-Hookean pulls it back.
  const StVenantKirchhoff stvk = makeModel<StVenantKirchhoff>();
  EXPECT_GT(uniaxialStress(stvk, -0.5), 0.0);
  EXPECT_LT(uniaxialStress(snh, -0.5), 0.0);
}

TEST(StableNeoHookean, ClothFiniteAndRestoringAtCollapse) {
  // A cloth triangle squashed along t2: F = T diag(1, s). For s > 0 this is the planar case, so
  // (T^T P)_22 = (2 mu + lambda)(s - 1). At s = 0 the triangle has no normal and J = |f1 x f2| has
  // a kink, but psi and P stay finite; any s > 0 is restoring.
  const StableNeoHookean snh = makeModel<StableNeoHookean>();
  const double k = 2.0 * kMu + kLambda;
  for (const DefGrad<3>& T : restFrames<3>()) {
    for (double s : {1e-8, 1e-3, 0.3}) {
      const DefGrad<3> F = T * diag(1.0, s);
      EXPECT_NEAR(snh.psi<3>(F, T), 0.5 * k * (s - 1.0) * (s - 1.0), 1e-13);
      EXPECT_NEAR((T.transpose() * snh.pk1<3>(F, T))(1, 1), k * (s - 1.0), 1e-12);
    }
    const DefGrad<3> collapsed = T * diag(1.0, 0.0);
    EXPECT_NEAR(snh.psi<3>(collapsed, T), 0.5 * k, 1e-14);
    EXPECT_TRUE(snh.pk1<3>(collapsed, T).allFinite());
    EXPECT_TRUE(snh.hessian<3>(collapsed, T).allFinite());
    EXPECT_TRUE(snh.projectedHessian<3>(collapsed, T).allFinite());
  }
}

TEST(NeoHookean, InfiniteOutsideItsDomainNeverNan) {
  const NeoHookean nh = makeModel<NeoHookean>();
  const double inf = std::numeric_limits<double>::infinity();
  for (const Eigen::Matrix2d& F : {diag(1.0, -0.5), diag(1.0, 0.0), diag(-1.0, 2.0),
                                   Eigen::Matrix2d::Zero().eval()}) {
    EXPECT_FALSE(nh.inDomain<2>(F)) << F;
    EXPECT_EQ(nh.psi<2>(F, planarIdentity()), inf) << F;
  }
  const Eigen::Vector3d a(1.0, 2.0, -0.5);
  for (const DefGrad<3>& T : restFrames<3>()) {
    DefGrad<3> lineCollapse, pointCollapse = DefGrad<3>::Zero(), squashed = T * diag(1.0, 0.0);
    lineCollapse << a, -3.0 * a;
    for (const DefGrad<3>& F : {lineCollapse, pointCollapse, squashed}) {
      EXPECT_FALSE(nh.inDomain<3>(F)) << F;
      EXPECT_EQ(nh.psi<3>(F, T), inf) << F;
    }
  }
  // Inside, psi is finite and grows without bound as J -> 0+ (the log barrier).
  double previous = uniaxialEnergy(nh, 0.5);
  for (double s : {1e-1, 1e-2, 1e-4, 1e-8, 1e-300}) {
    EXPECT_TRUE(nh.inDomain<2>(diag(1.0, s)));
    const double psi = uniaxialEnergy(nh, s);
    EXPECT_TRUE(std::isfinite(psi)) << s;
    EXPECT_GT(psi, previous) << s;
    EXPECT_LT(uniaxialStress(nh, s), 0.0) << s;
    previous = psi;
  }
}

TEST(NeoHookean, HandValueAtUniaxialStretch) {
  // F = diag(2, 1): I_C = 5, J = 2: psi = mu/2 (5 - 2) - mu log 2 + lambda/2 (log 2)^2.
  const NeoHookean nh = makeModel<NeoHookean>();
  const double log2 = std::log(2.0);
  EXPECT_NEAR(nh.psi<2>(diag(2.0, 1.0), planarIdentity()),
              1.5 * kMu - kMu * log2 + 0.5 * kLambda * log2 * log2, 1e-14);
}

// ---------------------------------------------------------------------------------------------
// Parameters and the run-time choice of model.
// ---------------------------------------------------------------------------------------------

TEST(Lame, FromYoungPoissonPlaneStress) {
  // mu = E / (2 (1 + nu)), lambda = E nu / (1 - nu^2), worked by hand.
  const Lame a = Lame::fromYoungPoisson(1000.0, 0.25);
  EXPECT_NEAR(a.mu, 400.0, 1e-12);                   // 1000 / 2.5
  EXPECT_NEAR(a.lambda, 800.0 / 3.0, 1e-12);         // 250 / 0.9375
  const Lame b = Lame::fromYoungPoisson(2.0e5, 0.3);
  EXPECT_NEAR(b.mu, 76923.076923076923, 1e-8);       // 2e5 / 2.6
  EXPECT_NEAR(b.lambda, 65934.065934065934, 1e-8);   // 6e4 / 0.91
  const Lame c = Lame::fromYoungPoisson(3.0, 0.0);
  EXPECT_DOUBLE_EQ(c.mu, 1.5);
  EXPECT_DOUBLE_EQ(c.lambda, 0.0);
}

TEST(MakeMaterial, BuildsEveryModelByName) {
  const std::vector<std::string> expected = {"linear", "stvk", "corotational",
                                             "arap", "neo_hookean", "stable_neo_hookean"};
  EXPECT_EQ(materialNames(), expected);
  for (const std::string& name : expected) {
    const Expected<Material> material = makeMaterial(name, Lame{kMu, kLambda});
    ASSERT_TRUE(material.ok()) << name << ": " << material.error();
    EXPECT_EQ(materialName(*material), name);
    EXPECT_EQ(materialNeedsPolar(*material), name == "corotational" || name == "arap") << name;
  }
}

TEST(MakeMaterial, UnknownNameListsTheKnownOnes) {
  const Expected<Material> material = makeMaterial("rubber", Lame{kMu, kLambda});
  ASSERT_FALSE(material.ok());
  EXPECT_NE(material.error().find("'rubber'"), std::string::npos) << material.error();
  for (const char* name :
       {"linear", "stvk", "corotational", "arap", "neo_hookean", "stable_neo_hookean"}) {
    EXPECT_NE(material.error().find(name), std::string::npos) << material.error();
  }
}
