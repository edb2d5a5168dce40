// The assembled membrane term: energy against closed forms, and the gradient and Hessian
// assembled through the fixed sparsity pattern against central finite differences of the
// energy and the gradient.
#include <gtest/gtest.h>

#include <memory>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <random>

#include "fem_cloth/core/membrane.h"

using namespace fem_cloth;

namespace {

struct Fixture {
  std::shared_ptr<const Mesh> mesh;
  std::shared_ptr<const RestState> rest;
};

Fixture makeFixture(int dim, int n = 4) {
  GridSpec spec;
  spec.rows = n;
  spec.cols = n + 1;
  spec.width = 0.8;
  spec.height = 0.6;
  spec.dim = dim;
  auto mesh = std::make_shared<Mesh>(*makeGrid(spec));
  auto rest = std::make_shared<RestState>(*computeRestState(*mesh));
  return {mesh, rest};
}

VectorX perturbed(const Mesh& mesh, double amount, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-amount, amount);
  VectorX x = mesh.restPositions;
  for (Eigen::Index i = 0; i < x.size(); ++i) x[i] += u(rng);
  return x;
}

SparseHessian patternFor(const Fixture& f, EnergyTerm& term) {
  std::vector<std::vector<Index>> stencils;
  term.appendStencils(&stencils);
  SparseHessian H(f.mesh->numVertices(), f.mesh->dim, stencils);
  term.bindHessian(H);
  return H;
}

void checkDerivatives(int dim, const std::string& model) {
  const Fixture f = makeFixture(dim);
  const Material material = *makeMaterial(model, Lame{3.0, 5.0});
  auto term = makeMembraneTerm(f.mesh, f.rest, material);
  SparseHessian H = patternFor(f, *term);
  // Moderate perturbation keeps Neo-Hookean elements inside J > 0.
  const VectorX x = perturbed(*f.mesh, 0.02, 7);
  VectorX g = VectorX::Zero(x.size());
  EvalRequest request;
  request.gradient = &g;
  request.hessian = &H;
  request.hessianMode = HessianMode::Exact;
  const EvalResult r = term->evaluate(x, request);
  ASSERT_TRUE(r.inDomain);
  const Eigen::MatrixXd K = Eigen::MatrixXd(H.matrix());
  // The central-difference error falls like h^2 until round-off takes over; for quadratic
  // energies (linear elasticity) it is at round-off for every h.
  const double scale = 1.0 + K.cwiseAbs().maxCoeff();
  std::vector<double> gradErrors, hessErrors;
  for (double h : {1e-2, 1e-3, 1e-4, 1e-5}) {
    double gradError = 0.0, hessError = 0.0;
    for (Eigen::Index i = 0; i < x.size(); ++i) {
      VectorX xp = x, xm = x;
      xp[i] += h;
      xm[i] -= h;
      EvalRequest energyOnly;
      const double fd = (term->evaluate(xp, energyOnly).energy -
                         term->evaluate(xm, energyOnly).energy) / (2 * h);
      gradError = std::max(gradError, std::abs(fd - g[i]));
      VectorX gp = VectorX::Zero(x.size()), gm = VectorX::Zero(x.size());
      EvalRequest gradOnly;
      gradOnly.energy = false;
      gradOnly.gradient = &gp;
      term->evaluate(xp, gradOnly);
      gradOnly.gradient = &gm;
      term->evaluate(xm, gradOnly);
      hessError = std::max(hessError, ((gp - gm) / (2 * h) - K.col(i)).cwiseAbs().maxCoeff());
    }
    gradErrors.push_back(gradError / scale);
    hessErrors.push_back(hessError / scale);
  }
  const double roundOff = 1e-9;
  for (const auto* errors : {&gradErrors, &hessErrors}) {
    const auto& e = *errors;
    EXPECT_LT(*std::min_element(e.begin(), e.end()), 1e-7) << model << " dim " << dim;
    if (e[0] > roundOff) {
      EXPECT_LT(e[1], 0.05 * e[0]) << model << " dim " << dim << ": error does not fall like h^2";
    }
  }
  // The Hessian is symmetric, and the projected one positive semi-definite.
  EXPECT_LT((K - K.transpose()).cwiseAbs().maxCoeff(), 1e-9 * (1.0 + K.norm()));
  H.setZero();
  request.hessianMode = HessianMode::Projected;
  request.gradient = nullptr;
  term->evaluate(x, request);
  const Eigen::MatrixXd Kp = Eigen::MatrixXd(H.matrix());
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Kp);
  EXPECT_GT(eig.eigenvalues().minCoeff(), -1e-9 * (1.0 + Kp.norm())) << model;
}

}  // namespace

class MembraneDerivatives : public testing::TestWithParam<std::string> {};

TEST_P(MembraneDerivatives, Planar) { checkDerivatives(2, GetParam()); }
TEST_P(MembraneDerivatives, Cloth) { checkDerivatives(3, GetParam()); }

INSTANTIATE_TEST_SUITE_P(AllModels, MembraneDerivatives,
                         testing::Values("linear", "stvk", "corotational", "arap", "neo_hookean",
                                         "stable_neo_hookean"));

TEST(Membrane, UniaxialStretchMatchesClosedForm) {
  // Stretching the whole sheet by s along x: F = diag(s, 1) in every element, so for StVK with
  // lambda = 0, E = area * mu (s^2 - 1)^2 / 4.
  for (int dim : {2, 3}) {
    const Fixture f = makeFixture(dim);
    const double mu = 2.5, s = 1.3;
    auto term = makeMembraneTerm(f.mesh, f.rest, *makeMaterial("stvk", Lame{mu, 0.0}));
    VectorX x = f.mesh->restPositions;
    for (Index i = 0; i < f.mesh->numVertices(); ++i) x[dim * i] *= s;
    const double expected = 0.8 * 0.6 * mu * (s * s - 1) * (s * s - 1) / 4;
    EXPECT_NEAR(term->evaluate(x, EvalRequest{}).energy, expected, 1e-12);
  }
}

TEST(Membrane, RigidMotionIsFreeForRotationInvariantModels) {
  const Fixture f = makeFixture(3);
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  VectorX x = f.mesh->restPositions;
  for (Index i = 0; i < f.mesh->numVertices(); ++i) {
    x.segment<3>(3 * i) = R * x.segment<3>(3 * i) + Eigen::Vector3d(0.1, -2, 5);
  }
  for (const std::string& model : materialNames()) {
    auto term = makeMembraneTerm(f.mesh, f.rest, *makeMaterial(model, Lame{1.0, 1.0}));
    const double e = term->evaluate(x, EvalRequest{}).energy;
    if (model == "linear") {
      EXPECT_GT(e, 1e-3) << "linear elasticity should see the rotation as strain";
    } else {
      EXPECT_NEAR(e, 0.0, 1e-13) << model;
    }
  }
}

TEST(Membrane, NeoHookeanReportsInvertedElement) {
  const Fixture f = makeFixture(2);
  auto term = makeMembraneTerm(f.mesh, f.rest, *makeMaterial("neo_hookean", Lame{1.0, 1.0}));
  VectorX x = f.mesh->restPositions;
  // Flip the sheet along y: every element inverts.
  for (Index i = 0; i < f.mesh->numVertices(); ++i) x[2 * i + 1] *= -1.0;
  const EvalResult r = term->evaluate(x, EvalRequest{});
  EXPECT_FALSE(r.inDomain);
  EXPECT_EQ(r.firstBadElement, 0);
  EXPECT_EQ(r.energy, kInfiniteEnergy);
  Index where = -1;
  EXPECT_NEAR(minAreaRatio(*f.mesh, *f.rest, x, &where), -1.0, 1e-12);
}
