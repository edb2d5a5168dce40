// The inversion-aware 2 x 2 SVD, the 3 x 2 thin SVD, the polar rotation built from them, and the
// area ratio J with its gradient. Singular values are checked against Eigen's JacobiSVD (an
// independent implementation), polar rotations against closed forms, and dJ/dF against central
// finite differences.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <cmath>
#include <string>
#include <vector>

#include "fem_cloth/core/svd.h"
#include "random_matrices.h"

using namespace fem_cloth;
using test_support::RandomMatrices;

namespace {

constexpr double kTol = 1e-12;

// Finite factors that multiply back to F.
template <int D>
void expectFiniteReconstruction(const Svd<D>& svd, const DefGrad<D>& F, const std::string& what) {
  ASSERT_TRUE(svd.U.allFinite() && svd.sigma.allFinite() && svd.V.allFinite()) << what;
  EXPECT_LT((svd.U * svd.sigma.asDiagonal() * svd.V.transpose() - F).cwiseAbs().maxCoeff(),
            kTol * (1.0 + F.norm()))
      << what;
}

// A proper rotation: orthogonal with determinant +1.
void expectRotation(const Eigen::Matrix2d& M, const std::string& what) {
  EXPECT_LT((M.transpose() * M - Eigen::Matrix2d::Identity()).cwiseAbs().maxCoeff(), kTol) << what;
  EXPECT_NEAR(M.determinant(), 1.0, kTol) << what;
}

// Singular values in decreasing order, from Eigen's Jacobi SVD.
Eigen::Vector2d referenceSingularValues(const Eigen::MatrixXd& F) {
  return Eigen::JacobiSVD<Eigen::MatrixXd>(F).singularValues();
}

// The planar polar rotation maximises tr(R^T F) over rotations R(a): d/da of
// cos(a) (F00 + F11) + sin(a) (F10 - F01) vanishes at a = atan2(F10 - F01, F00 + F11).
Eigen::Matrix2d planarPolarRotation(const Eigen::Matrix2d& F) {
  return Eigen::Rotation2Dd(std::atan2(F(1, 0) - F(0, 1), F(0, 0) + F(1, 1))).toRotationMatrix();
}

void checkPlanar(const Eigen::Matrix2d& F, const std::string& what) {
  const Svd<2> svd = svd2(F);
  expectFiniteReconstruction<2>(svd, F, what);
  const double scale = 1.0 + F.norm();
  expectRotation(svd.U, what + ": U");
  expectRotation(svd.V, what + ": V");
  EXPECT_GE(svd.sigma[0], std::abs(svd.sigma[1])) << what;
  // s1 s2 = det F carries the sign of the determinant into s2.
  EXPECT_NEAR(svd.sigma[0] * svd.sigma[1], F.determinant(), kTol * scale * scale) << what;
  if (std::abs(F.determinant()) > 1e-9) {
    EXPECT_EQ(svd.sigma[1] > 0.0, F.determinant() > 0.0) << what;
  }
  const Eigen::Vector2d reference = referenceSingularValues(F);
  EXPECT_NEAR(svd.sigma[0], reference[0], kTol * scale) << what;
  EXPECT_NEAR(std::abs(svd.sigma[1]), reference[1], kTol * scale) << what;
}

void checkCloth(const DefGrad<3>& F, const std::string& what) {
  const Svd<3> svd = svd3x2(F);
  expectFiniteReconstruction<3>(svd, F, what);
  const double scale = 1.0 + F.norm();
  EXPECT_LT((svd.U.transpose() * svd.U - Eigen::Matrix2d::Identity()).cwiseAbs().maxCoeff(), kTol)
      << what;
  expectRotation(svd.V, what + ": V");
  EXPECT_GE(svd.sigma[0], svd.sigma[1]) << what;
  EXPECT_GE(svd.sigma[1], 0.0) << what;
  const Eigen::Vector2d reference = referenceSingularValues(F);
  EXPECT_NEAR(svd.sigma[0], reference[0], kTol * scale) << what;
  EXPECT_NEAR(svd.sigma[1], reference[1], kTol * scale) << what;
  // f1 x f2 = det(diag(s) V^T) u1 x u2 = s1 s2 (u1 x u2): u1 x u2 is the deformed unit normal.
  const Eigen::Vector3d normal = svd.U.col(0).cross(svd.U.col(1));
  EXPECT_NEAR(normal.norm(), 1.0, kTol) << what;
  const Eigen::Vector3d areaVector = F.col(0).cross(F.col(1));
  EXPECT_LT((svd.sigma[0] * svd.sigma[1] * normal - areaVector).cwiseAbs().maxCoeff(),
            kTol * scale * scale)
      << what;
}

Eigen::Matrix2d planar(double a, double b, double c, double d) {
  Eigen::Matrix2d F;
  F << a, b, c, d;
  return F;
}

DefGrad<3> cloth(const Eigen::Vector3d& f1, const Eigen::Vector3d& f2) {
  DefGrad<3> F;
  F << f1, f2;
  return F;
}

}  // namespace

TEST(Svd2, RandomMatricesReconstructWithRotationsAndSignedValues) {
  RandomMatrices random(11);
  for (int k = 0; k < 500; ++k) {
    checkPlanar(random.matrix<2, 2>(-2.0, 2.0), "random F #" + std::to_string(k));
  }
}

TEST(Svd2, DegenerateInputsStayFiniteAndReconstruct) {
  const Eigen::Matrix2d rotation = Eigen::Rotation2Dd(0.3).toRotationMatrix();
  struct Case {
    std::string name;
    Eigen::Matrix2d F;
    Eigen::Vector2d sigma;  // expected, by hand
  };
  const std::vector<Case> cases = {
      {"zero", Eigen::Matrix2d::Zero(), {0.0, 0.0}},
      // Rank one: the outer product (1, 2)(1, 2)^T has the single singular value 1 + 4.
      {"rank one", planar(1, 2, 2, 4), {5.0, 0.0}},
      {"rank one, one column", planar(0, 0, 0, 3), {3.0, 0.0}},
      {"repeated, 2 I", 2.0 * Eigen::Matrix2d::Identity(), {2.0, 2.0}},
      {"repeated, 2 R", 2.0 * rotation, {2.0, 2.0}},
      {"rotation by pi, -I", -Eigen::Matrix2d::Identity(), {1.0, 1.0}},
      {"inverted, diag(1, -0.5)", planar(1, 0, 0, -0.5), {1.0, -0.5}},
      {"reflection, diag(-1, 1)", planar(-1, 0, 0, 1), {1.0, -1.0}},
      {"inverted and rotated", rotation * planar(0.5, 0, 0, -2), {2.0, -0.5}},
      {"both negative, diag(-2, -3)", planar(-2, 0, 0, -3), {3.0, 2.0}},
      {"tiny", 1e-200 * planar(1, 2, -3, 0.5), {0.0, 0.0}},
  };
  for (const Case& c : cases) {
    checkPlanar(c.F, c.name);
    const Svd<2> svd = svd2(c.F);
    EXPECT_NEAR(svd.sigma[0], c.sigma[0], kTol) << c.name;
    EXPECT_NEAR(svd.sigma[1], c.sigma[1], kTol) << c.name;
  }
}

TEST(Svd2, PolarRotationIsTheRotationClosestToF) {
  RandomMatrices random(12);
  std::vector<Eigen::Matrix2d> samples = {planar(1, 0, 0, -0.5), planar(2, 1, 0, 3),
                                          planar(0.2, -1, 1.5, -0.3)};
  for (int k = 0; k < 200; ++k) samples.push_back(random.matrix<2, 2>(-2.0, 2.0));
  for (const Eigen::Matrix2d& F : samples) {
    if (std::abs(F.trace()) + std::abs(F(1, 0) - F(0, 1)) < 1e-6) continue;  // R undefined
    const Svd<2> svd = svd2(F);
    const Eigen::Matrix2d R = svd.rotation();
    expectRotation(R, "polar R");
    EXPECT_LT((R - planarPolarRotation(F)).cwiseAbs().maxCoeff(), 1e-10) << F;
    // F = R S with S symmetric (indefinite when F is inverted).
    const Eigen::Matrix2d S = R.transpose() * F;
    EXPECT_LT(std::abs(S(0, 1) - S(1, 0)), 1e-12 * (1.0 + F.norm())) << F;
    EXPECT_LT((svd.stretch() - S).cwiseAbs().maxCoeff(), 1e-12 * (1.0 + F.norm())) << F;
  }
}

TEST(Svd3x2, RandomMatricesReconstructWithOrthonormalColumns) {
  RandomMatrices random(13);
  for (int k = 0; k < 500; ++k) {
    checkCloth(random.matrix<3, 2>(-2.0, 2.0), "random F #" + std::to_string(k));
  }
}

TEST(Svd3x2, DegenerateInputsStayFiniteAndReconstruct) {
  const Eigen::Vector3d a(1.0, 2.0, 2.0), b(-2.0, 1.0, 0.5);
  RandomMatrices random(14);
  const DefGrad<3> T = random.restFrame();
  struct Case {
    std::string name;
    DefGrad<3> F;
    Eigen::Vector2d sigma;  // expected, by hand (|a| = 3)
  };
  const std::vector<Case> cases = {
      {"zero", DefGrad<3>::Zero(), {0.0, 0.0}},
      {"first column zero", cloth(Eigen::Vector3d::Zero(), a), {3.0, 0.0}},
      {"second column zero", cloth(a, Eigen::Vector3d::Zero()), {3.0, 0.0}},
      // Parallel columns a and -2a: the rank-one a (1, -2), singular value |a| |(1, -2)|.
      {"collapsed onto a line", cloth(a, -2.0 * a), {3.0 * std::sqrt(5.0), 0.0}},
      {"repeated, 2 T", 2.0 * T, {2.0, 2.0}},
      {"rest frame", T, {1.0, 1.0}},
      {"tiny", 1e-200 * cloth(a, b), {0.0, 0.0}},
  };
  for (const Case& c : cases) {
    checkCloth(c.F, c.name);
    const Svd<3> svd = svd3x2(c.F);
    EXPECT_NEAR(svd.sigma[0], c.sigma[0], kTol * 10) << c.name;
    EXPECT_NEAR(svd.sigma[1], c.sigma[1], kTol * 10) << c.name;
  }
}

// R has orthonormal columns and, for a full-rank F, is the polar factor F (F^T F)^(-1/2).
template <class Rotation>
void expectPolarFactors(unsigned seed, Rotation rotation) {
  RandomMatrices random(seed);
  for (int k = 0; k < 200; ++k) {
    const DefGrad<3> F = random.matrix<3, 2>(-2.0, 2.0);
    const DefGrad<3> R = rotation(F);
    EXPECT_LT((R.transpose() * R - Eigen::Matrix2d::Identity()).cwiseAbs().maxCoeff(), kTol);
    const Eigen::Matrix2d C = F.transpose() * F;
    if (C.determinant() < 1e-6) continue;
    const Eigen::Matrix2d inverseRoot =
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(C).operatorInverseSqrt();
    EXPECT_LT((R - F * inverseRoot).cwiseAbs().maxCoeff(), 1e-9) << F;
  }
}

TEST(Svd3x2, PolarRotationIsOrthonormalAndMatchesTheInverseSquareRoot) {
  expectPolarFactors(15, [](const DefGrad<3>& F) { return DefGrad<3>(svd3x2(F).rotation()); });
}

// The SVD-free rotation the ARAP membrane and projective dynamics use: the same polar factor,
// checked against F (F^T F)^(-1/2) from Eigen's eigensolver, and finite where F loses rank.
TEST(Svd3x2, PolarRotationWithoutTheSvdMatchesTheInverseSquareRoot) {
  expectPolarFactors(16, [](const DefGrad<3>& F) { return polarRotation3x2(F); });
  DefGrad<3> collapsed = DefGrad<3>::Zero();
  collapsed(0, 0) = 1.0;  // the second column gone
  for (const DefGrad<3>& F : {DefGrad<3>(DefGrad<3>::Zero()), collapsed}) {
    const DefGrad<3> R = polarRotation3x2(F);
    EXPECT_TRUE(R.allFinite());
    EXPECT_LT((R.transpose() * R - Eigen::Matrix2d::Identity()).cwiseAbs().maxCoeff(), kTol);
  }
}

TEST(AreaRatio, HandValues) {
  EXPECT_DOUBLE_EQ(areaRatio(DefGrad<2>(planar(2, 0, 0, 3))), 6.0);
  EXPECT_DOUBLE_EQ(areaRatio(DefGrad<2>(planar(1, 2, 3, 4))), -2.0);
  // (1, 0, 0) x (1, 2, 2) = (0, -2, 2).
  EXPECT_NEAR(areaRatio(cloth({1, 0, 0}, {1, 2, 2})), 2.0 * std::sqrt(2.0), 1e-15);
  EXPECT_EQ(areaRatio(cloth({1, 2, 3}, {-2, -4, -6})), 0.0);
  // A collapsed cloth triangle has no normal: the gradient is the zero matrix, not NaN.
  EXPECT_TRUE(areaRatioGradient(cloth({1, 2, 3}, {2, 4, 6})).isZero(0.0));
}

template <int D>
void expectAreaRatioGradientMatchesDifferences(const DefGrad<D>& F) {
  const DefGrad<D> G = areaRatioGradient(F);
  const double h = 1e-6;
  for (int c = 0; c < 2; ++c) {
    for (int r = 0; r < D; ++r) {
      DefGrad<D> Fp = F, Fm = F;
      Fp(r, c) += h;
      Fm(r, c) -= h;
      const double fd = (areaRatio(Fp) - areaRatio(Fm)) / (2.0 * h);
      EXPECT_NEAR(G(r, c), fd, 1e-8) << "entry (" << r << ", " << c << ") of\n" << F;
    }
  }
}

TEST(AreaRatio, GradientMatchesCentralDifferences) {
  RandomMatrices random(16);
  for (int k = 0; k < 100; ++k) {
    expectAreaRatioGradientMatchesDifferences<2>(random.matrix<2, 2>(-2.0, 2.0));
    const DefGrad<3> F = random.matrix<3, 2>(-2.0, 2.0);
    if (areaRatio(F) > 1e-2) expectAreaRatioGradientMatchesDifferences<3>(F);
  }
}
