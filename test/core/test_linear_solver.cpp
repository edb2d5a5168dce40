// The sparse solves behind every Newton step: each kind solves a system whose solution is known
// beforehand, keeps its analysis while the pattern stays, re-analyses when it grows, and refuses
// a matrix that is not positive definite; `auto` picks by size as docs/scenes.md says.
#include <gtest/gtest.h>

#include <Eigen/SparseCore>
#include <vector>

#include "fem_cloth/core/integrators/linear_solver.h"

namespace fem_cloth {
namespace {

using Matrix = LinearSolver::Matrix;

// A 3-DOF-per-node stiffness of an n x n grid of springs (graph Laplacian times k, coupled in x,
// y, z alike) plus a mass m on the diagonal: symmetric positive definite, stored whole, with the
// pattern a cloth Hessian has. `extra` couples node 0 with the last node (a self-contact pair).
Matrix gridSystem(int n, double k, double m, bool extra = false) {
  const int nodes = n * n;
  std::vector<Eigen::Triplet<double, int>> t;
  auto spring = [&](int a, int b) {
    for (int d = 0; d < 3; ++d) {
      t.emplace_back(3 * a + d, 3 * a + d, k);
      t.emplace_back(3 * b + d, 3 * b + d, k);
      t.emplace_back(3 * a + d, 3 * b + d, -k);
      t.emplace_back(3 * b + d, 3 * a + d, -k);
    }
  };
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) {
      const int v = r * n + c;
      if (c + 1 < n) spring(v, v + 1);
      if (r + 1 < n) spring(v, v + n);
      if (r + 1 < n && c + 1 < n) spring(v, v + n + 1);
    }
  }
  if (extra) spring(0, nodes - 1);
  for (int i = 0; i < 3 * nodes; ++i) t.emplace_back(i, i, m * (1.0 + 0.01 * (i % 7)));
  Matrix A(3 * nodes, 3 * nodes);
  A.setFromTriplets(t.begin(), t.end());
  A.makeCompressed();
  return A;
}

// A known solution, and its right-hand side by a plain sparse product (not by any solver).
VectorX knownSolution(Index size) {
  VectorX x(size);
  for (Index i = 0; i < size; ++i) x[i] = std::sin(0.37 * static_cast<double>(i)) + 0.1;
  return x;
}

double relativeError(const VectorX& x, const VectorX& truth) { return (x - truth).norm() / truth.norm(); }

class EveryKind : public ::testing::TestWithParam<LinearSolverKind> {};

TEST_P(EveryKind, SolvesASystemWithAKnownSolution) {
  if (GetParam() != LinearSolverKind::Ldlt && GetParam() != LinearSolverKind::Cg && !cholmodAvailable()) {
    GTEST_SKIP() << "built without CHOLMOD";
  }
  LinearSolverSettings settings;
  settings.kind = GetParam();
  settings.cgTolerance = 1e-12;
  const Matrix A = gridSystem(12, 500.0, 2.0);
  auto solver = makeLinearSolver(settings, A.rows());
  ASSERT_TRUE(solver->compute(A));
  const VectorX truth = knownSolution(A.rows());
  const VectorX b = A * truth;
  VectorX x = VectorX::Zero(A.rows());
  ASSERT_TRUE(solver->solve(b, x));
  EXPECT_LT(relativeError(x, truth), 1e-9) << solver->name();

  // New values, same pattern: factorised again without a new analysis.
  const Matrix A2 = gridSystem(12, 80.0, 5.0);
  ASSERT_TRUE(solver->compute(A2));
  const VectorX b2 = A2 * truth;
  ASSERT_TRUE(solver->solve(b2, x));
  EXPECT_LT(relativeError(x, truth), 1e-9) << solver->name();
  if (GetParam() != LinearSolverKind::Cg) {
    EXPECT_EQ(solver->analyses(), 1) << solver->name();
  }

  // A pattern that grew (a self-contact pair): analysed again, and still right.
  const Matrix A3 = gridSystem(12, 80.0, 5.0, true);
  ASSERT_TRUE(solver->compute(A3));
  const VectorX b3 = A3 * truth;
  ASSERT_TRUE(solver->solve(b3, x));
  EXPECT_LT(relativeError(x, truth), 1e-9) << solver->name();
  if (GetParam() != LinearSolverKind::Cg) {
    EXPECT_EQ(solver->analyses(), 2) << solver->name();
  }
}

INSTANTIATE_TEST_SUITE_P(LinearSolver, EveryKind,
                         ::testing::Values(LinearSolverKind::Auto, LinearSolverKind::Simplicial,
                                           LinearSolverKind::Cholmod, LinearSolverKind::Ldlt,
                                           LinearSolverKind::Cg),
                         [](const auto& info) { return linearSolverName(info.param); });

TEST(LinearSolver, CholeskyRefusesAMatrixThatIsNotPositiveDefinite) {
  if (!cholmodAvailable()) GTEST_SKIP() << "built without CHOLMOD";
  // The spring matrix with a negative mass: its constant mode has Rayleigh quotient -1 < 0.
  const Matrix A = gridSystem(5, 100.0, -1.0);
  for (LinearSolverKind kind : {LinearSolverKind::Simplicial, LinearSolverKind::Cholmod}) {
    LinearSolverSettings settings;
    settings.kind = kind;
    auto solver = makeLinearSolver(settings, A.rows());
    EXPECT_FALSE(solver->compute(A)) << solver->name();
  }
}

TEST(LinearSolver, AutoPicksByTheFlopsOfTheFactor) {
  if (!cholmodAvailable()) GTEST_SKIP() << "built without CHOLMOD";
  // docs/scenes.md: CG above 200000 unknowns; below, simplicial up to 1e7 flops of the factor.
  EXPECT_EQ(resolveLinearSolverKind(LinearSolverKind::Auto, 200001), LinearSolverKind::Cg);
  EXPECT_EQ(resolveLinearSolverKind(LinearSolverKind::Ldlt, 10), LinearSolverKind::Ldlt);
  LinearSolverSettings settings;  // auto
  // 6x6 nodes, 108 unknowns: no factor of them needs more than a dense one, 108^3/3 = 4.2e5 flops.
  const Matrix small = gridSystem(6, 500.0, 2.0);
  auto a = makeLinearSolver(settings, small.rows());
  ASSERT_TRUE(a->compute(small));
  EXPECT_EQ(a->name(), "simplicial");
  // 104x104 nodes: a k x k grid has treewidth k, so any elimination order makes a dense front of
  // at least k + 1 = 105 nodes, 315 unknowns: at least 315^3/3 = 1.04e7 flops.
  const Matrix large = gridSystem(104, 500.0, 2.0);
  auto b = makeLinearSolver(settings, large.rows());
  ASSERT_TRUE(b->compute(large));
  EXPECT_EQ(b->name(), "cholmod");
  const VectorX truth = knownSolution(large.rows());
  VectorX x;
  ASSERT_TRUE(b->solve(large * truth, x));
  EXPECT_LT(relativeError(x, truth), 1e-9);
}

TEST(LinearSolver, UnknownKindIsNamedWithTheKnownOnes) {
  Expected<LinearSolverKind> kind = parseLinearSolverKind("superlu");
  ASSERT_FALSE(kind);
  EXPECT_NE(kind.error().find("'superlu'"), std::string::npos) << kind.error();
  EXPECT_NE(kind.error().find("simplicial"), std::string::npos) << kind.error();
}

}  // namespace
}  // namespace fem_cloth
