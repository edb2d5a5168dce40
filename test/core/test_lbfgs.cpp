// The quasi-Newton solver of the implicit steppers (integrator.solver: lbfgs; solvers/lbfgs.h,
// solvers/initial_hessian.h): its pieces against closed forms, its solutions against Newton's
// and against a static closed form, its fallback, and its key.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <iostream>
#include <vector>

#include "config_scene.h"
#include "fem_cloth/core/integrators/implicit.h"
#include "fem_cloth/core/solvers/lbfgs.h"
#include "fem_cloth/core/energy_forms.h"
#include "fem_cloth/core/materials/materials.h"
#include "test_support.h"

namespace fem_cloth::test {
namespace {

// A random SPD matrix A = Q D Q^T with eigenvalues from 1 to 100.
Eigen::MatrixXd spdMatrix(int n, unsigned seed) {
  std::srand(seed);
  const Eigen::MatrixXd q = Eigen::MatrixXd::Random(n, n).householderQr().householderQ();
  Eigen::VectorXd d(n);
  for (int i = 0; i < n; ++i) d[i] = 1.0 + 99.0 * i / (n - 1);
  return q * d.asDiagonal() * q.transpose();
}

}  // namespace

// Without pairs the two-loop recursion is H0 itself.
TEST(LbfgsHistory, WithoutPairsAppliesTheInitialInverse) {
  LbfgsHistory history(4);
  const VectorX q = VectorX::LinSpaced(5, 1.0, 5.0);
  VectorX out;
  history.apply(q, [](const VectorX& v, VectorX& z) { z = 2.0 * v; }, out);
  EXPECT_LT((out - 2.0 * q).norm(), 1e-15);
}

// Nocedal & Wright, (6.17): the BFGS inverse satisfies the secant equation H y = s of its newest
// pair; and with pairs of a quadratic (y = A s), an exact initial inverse H0 = A^-1 stays exact:
// H q = A^-1 q, so the first direction -H g is Newton's step, which minimises the quadratic in
// one iteration.
TEST(LbfgsHistory, SecantEquationAndExactInitialInverse) {
  const int n = 6;
  const Eigen::MatrixXd A = spdMatrix(n, 7);
  const Eigen::MatrixXd Ainv = A.inverse();
  LbfgsHistory history(3);
  std::srand(11);
  VectorX x = VectorX::Zero(n);
  for (int k = 0; k < 5; ++k) {
    const VectorX xNew = x + VectorX::Random(n);
    EXPECT_TRUE(history.add(xNew, x, A * xNew, A * x));
    x = xNew;
  }
  EXPECT_EQ(history.stored(), 3);
  // The newest pair (s, y = A s): H y = s with H0 = I.
  const VectorX s = VectorX::Random(n), x0 = VectorX::Random(n);
  ASSERT_TRUE(history.add(x0 + s, x0, A * (x0 + s), A * x0));
  VectorX out;
  history.apply(A * s, [](const VectorX& v, VectorX& z) { z = v; }, out);
  EXPECT_LT((out - s).norm(), 1e-10 * s.norm());
  // H0 = A^-1: H = A^-1. Phi = 1/2 x^T A x - b^T x from x0: x0 - H (A x0 - b) = A^-1 b.
  const VectorX b = VectorX::Random(n);
  history.apply(A * x0 - b, [&](const VectorX& v, VectorX& z) { z = Ainv * v; }, out);
  EXPECT_LT((x0 - out - Ainv * b).norm(), 1e-10 * (Ainv * b).norm());
  // A pair without curvature (s.y <= 0) is not kept.
  EXPECT_FALSE(history.add(x0 + s, x0, A * x0, A * x0));
  EXPECT_EQ(history.stored(), 3);
}

// For the ARAP membrane the initial Hessian's L (the partial trace of the rest Hessian / 3) is
// half projective dynamics' matrix sum_t 2 mu A_t G_t G_t^T, built by the membrane's projective
// form from the rest shape alone: ARAP's rest Hessian is 2 mu on the symmetric in-plane part of
// dF, whose partial trace is 3 mu A G G^T (initial_hessian.h).
TEST(InitialHessian, IsHalfProjectiveDynamicsMatrixForArap) {
  Simulation sim = mustBuild(loadScene(std::string(FEM_CLOTH_CONFIG_DIR) + "/hanging_cloth.yaml",
                                      {"mesh.rows=5", "mesh.cols=5", "material.model=arap",
                                       "integrator.name=backward_euler"})
                                 .value());
  Model& model = sim.simulator->model();
  InitialHessian initial;
  std::string error;
  const std::vector<char> pinned(model.numDofs(), 0);
  ASSERT_TRUE(initial.prepare(model, pinned, 1.0, 1.0, model.mesh().restPositions, &error)) << error;
  std::vector<Eigen::Triplet<double>> triplets;
  model.term(0).projectiveForm()->appendProjectiveMatrix(&triplets);
  InitialHessian::Matrix expected(model.numVertices(), model.numVertices());
  expected.setFromTriplets(triplets.begin(), triplets.end());
  expected *= 0.5;
  const Eigen::MatrixXd difference = Eigen::MatrixXd(initial.laplacian()) - Eigen::MatrixXd(expected);
  EXPECT_LT(difference.cwiseAbs().maxCoeff(), 1e-9 * Eigen::MatrixXd(expected).cwiseAbs().maxCoeff());
}

// With contact blocks D (3 x 3 at some vertices), H0 is conjugate gradients on (B0 x I3 + D)
// preconditioned by B0's factor: run to convergence it is the exact inverse, checked against a
// dense solve of B0 x I3 + D built from the Laplacian and the masses; cut to two iterations it is
// inexact but still gives q.z > 0 (the L-BFGS direction descends).
TEST(InitialHessian, ContactBlocksByConjugateGradients) {
  Simulation sim = mustBuild(loadScene(std::string(FEM_CLOTH_CONFIG_DIR) + "/hanging_cloth.yaml",
                                      {"mesh.rows=5", "mesh.cols=5", "integrator.name=backward_euler"})
                                 .value());
  Model& model = sim.simulator->model();
  const Index n = model.numVertices();
  const std::vector<char> pinned(model.numDofs(), 0);
  const double a = 1.0, b = 1e-4;  // B0 = M + 1e-4 L
  // Barrier-like blocks: 1e3 x the largest entry of B0 along a tilted normal, at every third vertex.
  const Eigen::Vector3d normal = Eigen::Vector3d(0.3, -0.5, 1.0).normalized();
  std::vector<InitialHessian::ContactBlock> blocks;
  auto source = [&](const VectorX&, std::vector<InitialHessian::ContactBlock>& out) { out = blocks; };
  for (int iterations : {200, 2}) {
    InitialHessian initial;
    initial.setContact(source, {false, 3.0, false, iterations, 1e-14});
    std::string error;
    ASSERT_TRUE(initial.prepare(model, pinned, a, b, model.mesh().restPositions, &error)) << error;
    Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(3 * n, 3 * n);
    const Eigen::MatrixXd L = Eigen::MatrixXd(initial.laplacian());
    for (Index u = 0; u < n; ++u) {
      for (Index v = 0; v < n; ++v) {
        for (int c = 0; c < 3; ++c) dense(3 * u + c, 3 * v + c) = b * L(u, v) + (u == v ? a * model.vertexMasses()[u] : 0.0);
      }
    }
    const double scale = 1e3 * dense.cwiseAbs().maxCoeff();
    blocks.clear();
    for (Index v = 0; v < n; v += 3) blocks.push_back({v, scale * normal * normal.transpose()});
    for (const auto& block : blocks) dense.block<3, 3>(3 * block.vertex, 3 * block.vertex) += block.block;
    ASSERT_TRUE(initial.prepare(model, pinned, a, b, model.mesh().restPositions, &error)) << error;
    ASSERT_EQ(initial.contactVertices(), blocks.size());
    std::srand(7);
    const VectorX q = VectorX::Random(3 * n);
    VectorX z;
    initial.applyInverse(q, z);
    const VectorX exact = dense.ldlt().solve(q);
    if (iterations == 200) {
      EXPECT_LT((z - exact).norm(), 1e-8 * exact.norm());
    } else {
      EXPECT_GT(q.dot(z), 0.0);
      EXPECT_GT((z - exact).norm(), 1e-8 * exact.norm());  // really cut short
    }
  }
}

namespace {

struct SolvedRun {
  VectorX x;
  int quasiNewton = 0, newton = 0, fallbacks = 0, steps = 0;
  double tolerance = 0.0;  // sum over the steps of the largest tolerance a vertex had (m)
  int factorisations = 0;
  double moved = 0.0;  // the farthest a vertex moved in the run (m)
  /// Counts a step's iterations and adds its tolerance (error ratio and cap 1e-6, floor 1e-12):
  /// the bound of every vertex is cap x its motion + floor (acceptance.h); the largest.
  void record(const StepReport& r, Simulator& s, VectorX& before) {
    quasiNewton += r.quasiNewtonIterations;
    newton += r.newtonIterations;
    fallbacks += r.solverFallbacks;
    ++steps;
    double motion = 0.0;
    for (Index v = 0; v < s.model().numVertices(); ++v) {
      motion = std::max(motion, (s.state().x.segment<3>(3 * v) - before.segment<3>(3 * v)).norm());
    }
    tolerance += 1e-6 * motion + 1e-12 * restBoundingBoxDiagonal(s.model().mesh());
    before = s.state().x;
  }
};

// Error ratio and cap 1e-6, as test_acceptance's DefaultTolerance (SolvedRun::record's bound).
void tightTolerance(Scene& scene) {
  scene.displacement.ratio = scene.displacement.cap = 1e-6;
  scene.displacement.floor = 1e-12;
}

double worstVertex(const VectorX& a, const VectorX& b) {
  double worst = 0.0;
  for (Index v = 0; v < a.size() / 3; ++v) worst = std::max(worst, (a.segment<3>(3 * v) - b.segment<3>(3 * v)).norm());
  return worst;
}

// 0.04 s of the 9 x 9 hanging cloth (falling from two corners) with mid-edge bending, converged
// tightly (error ratio and cap 1e-6, as test_acceptance's DefaultTolerance); L-BFGS may take up
// to lbfgsMaxIterations per step (linear convergence needs many to reach 1e-6). The linear
// membrane leaves its validity range in the fifth step.
SolvedRun hangingCloth(const std::string& material, const std::string& solver, int lbfgsMaxIterations = 10'000,
                       const std::string& integrator = "backward_euler") {
  Scene scene = loadScene(std::string(FEM_CLOTH_CONFIG_DIR) + "/hanging_cloth.yaml",
                          {"integrator.name=" + integrator, "integrator.solver=" + solver,
                           "integrator.lbfgs_max_iterations=" + std::to_string(lbfgsMaxIterations)})
                    .value();
  scene.grid.rows = scene.grid.cols = 9;
  scene.materialModel = material;
  scene.bendingModel = BendingModel::Midedge;
  scene.bendingStiffness = 1e-3;
  tightTolerance(scene);
  Simulation sim = mustBuild(scene);
  Simulator& s = *sim.simulator;
  SolvedRun out;
  VectorX before = s.state().x;
  const VectorX start = before;
  const std::string error = run(sim, 4, [&](int, const StepReport& r) { out.record(r, s, before); });
  EXPECT_EQ(error, "") << material << " / " << solver;
  out.x = s.state().x;
  out.moved = worstVertex(start, out.x);
  if (auto* implicit = dynamic_cast<ImplicitIntegrator*>(&s.integrator())) {
    out.factorisations = implicit->initialHessian().factorisations();
  }
  return out;
}

}  // namespace

// Both solvers stop when the error estimate of their solution is within the tolerance, so each
// step's two solutions differ by at most twice it; backward Euler carries a difference of the
// positions into the next step without amplifying it (an L-stable scheme on a damped cloth), so
// after the run they differ by at most 2 x the sum of the steps' tolerances; the estimate of
// L-BFGS (the next quasi-Newton step, scaled by 1 / (1 - theta)) is an estimate, so the test
// allows 10 x that. The cloth falls about 8 mm in the run: the comparison is not between zeros.
class AgreesWithNewton : public ::testing::TestWithParam<std::string> {};

TEST_P(AgreesWithNewton, WithinTheTolerance) {
  const std::string material = GetParam();
  const SolvedRun newton = hangingCloth(material, "newton"), lbfgs = hangingCloth(material, "lbfgs");
  const double difference = worstVertex(newton.x, lbfgs.x), bound = 10.0 * 2.0 * lbfgs.tolerance;
  std::cout << material << ": Newton " << newton.newton << " iterations, L-BFGS " << lbfgs.quasiNewton
            << " iterations (" << lbfgs.fallbacks << " fallbacks, " << lbfgs.newton
            << " Newton iterations in them, " << lbfgs.factorisations << " factorisations); they differ by "
            << difference << " m, bound " << bound << " m\n";
  EXPECT_GT(newton.moved, 5e-3);
  EXPECT_GT(lbfgs.quasiNewton, 0);
  EXPECT_EQ(lbfgs.fallbacks, 0);  // L-BFGS itself converged
  EXPECT_EQ(newton.quasiNewton, 0);
  EXPECT_EQ(lbfgs.factorisations, 1);  // pins, dt and damping constant: B0 factorised once
  EXPECT_LE(difference, bound);
}

INSTANTIATE_TEST_SUITE_P(EveryMaterial, AgreesWithNewton, ::testing::ValuesIn(materialNames()));

// The same bound for BDF2 (its first step backward Euler, then second order: B0 is factorised
// again once for BDF2's c^2 = 4/9 h^2).
TEST(Bdf2, AgreesWithNewtonWithinTheTolerance) {
  const SolvedRun newton = hangingCloth("stvk", "newton", 10'000, "bdf2");
  const SolvedRun lbfgs = hangingCloth("stvk", "lbfgs", 10'000, "bdf2");
  const double difference = worstVertex(newton.x, lbfgs.x), bound = 10.0 * 2.0 * lbfgs.tolerance;
  std::cout << "bdf2: L-BFGS " << lbfgs.quasiNewton << " iterations, " << lbfgs.factorisations
            << " factorisations; differs from Newton by " << difference << " m, bound " << bound << " m\n";
  EXPECT_EQ(lbfgs.fallbacks, 0);
  EXPECT_EQ(lbfgs.factorisations, 2);
  EXPECT_LE(difference, bound);
}

// A stall: L-BFGS allowed one iteration per substep cannot reach the tight tolerance, so every
// substep falls back to Newton, which finishes it from where L-BFGS stopped; the run then is
// Newton's to within the same bound as above.
TEST(Fallback, NewtonFinishesEverySubstepWhereLbfgsStalls) {
  const SolvedRun newton = hangingCloth("stvk", "newton"), stalled = hangingCloth("stvk", "lbfgs", 1);
  const double difference = worstVertex(newton.x, stalled.x), bound = 10.0 * 2.0 * stalled.tolerance;
  std::cout << "stalled: " << stalled.quasiNewton << " L-BFGS iterations, " << stalled.fallbacks << " fallbacks, "
            << stalled.newton << " Newton iterations; differs from Newton by " << difference << " m, bound " << bound << " m\n";
  EXPECT_EQ(stalled.fallbacks, stalled.steps);  // one substep per step, each fell back
  EXPECT_EQ(stalled.quasiNewton, stalled.steps);
  EXPECT_GT(stalled.newton, 0);
  EXPECT_LE(difference, bound);
}

// integrator.solver takes newton or lbfgs (backward Euler and BDF2 list it among their keys).
TEST(SolverKey, BadValuesAreRefusedByName) {
  const std::string path = std::string(FEM_CLOTH_CONFIG_DIR) + "/hanging_cloth.yaml";
  Expected<Scene> typo = loadScene(path, {"integrator.name=backward_euler", "integrator.solver=lbgfs"});
  ASSERT_FALSE(typo);
  EXPECT_NE(typo.error().find("integrator.solver"), std::string::npos) << typo.error();
  EXPECT_NE(typo.error().find("unknown solver 'lbgfs' (known: newton, lbfgs)"), std::string::npos) << typo.error();
  Expected<Scene> memory = loadScene(path, {"integrator.name=bdf2", "integrator.solver=lbfgs", "integrator.lbfgs_memory=0"});
  ASSERT_FALSE(memory);
  EXPECT_NE(memory.error().find("integrator.lbfgs_memory"), std::string::npos) << memory.error();
  for (const char* integrator : {"backward_euler", "bdf2"}) {
    Expected<Scene> ok = loadScene(path, {std::string("integrator.name=") + integrator, "integrator.solver=lbfgs"});
    EXPECT_TRUE(ok) << (ok ? "" : ok.error());
  }
}

// A strip 0.05 m x 1 m (3 x 21 vertices) hanging from its top edge under its own weight, Poisson
// ratio 0 (so the clamp at the top does not matter: no transverse contraction to hold back) and
// E h = 1000 N/m: every material is then a bar of stiffness E h w at small strain (strain <= 2e-3
// here), whose tension at a height s above the bottom is the weight below, rho g w s, so the
// bottom drops by the integral of the strain, rho g L^2 / (2 E h) = 0.98 mm (the static stretch
// of each element is its load over its stiffness). Backward Euler with dt = 1 s damps every mode
// out in a few steps (L-stable), so after 20 steps the strip is static.
class HangingStrip : public ::testing::TestWithParam<std::string> {};

TEST_P(HangingStrip, StretchesByItsWeightOverItsStiffness) {
  const double length = 1.0, width = 0.05, areal = 0.2, youngThickness = 1000.0;
  Scene s;
  s.name = "strip";
  s.grid.rows = 21;
  s.grid.cols = 3;
  s.grid.width = width;
  s.grid.height = length;
  s.materialModel = GetParam();
  s.thickness = 1e-3;
  s.youngsModulus = youngThickness / s.thickness;
  s.poissonRatio = 0.0;
  s.density = areal / s.thickness;
  s.gravity = Eigen::Vector3d(0.0, -kG, 0.0);
  s.integrator = "backward_euler";
  s.integratorOptions.edit<ImplicitSolverSettings>("backward_euler").kind = ImplicitSolver::Lbfgs;
  s.dt = 1.0;
  ScenePin pin;
  pin.select.gridEdge = "last_row";  // y = length
  s.pins.push_back(pin);
  Simulation sim = mustBuild(s);
  Simulator& simulator = *sim.simulator;
  int quasiNewton = 0, fallbacks = 0;
  const std::string error = run(sim, 20, [&](int, const StepReport& r) {
    quasiNewton += r.quasiNewtonIterations;
    fallbacks += r.solverFallbacks;
  });
  ASSERT_EQ(error, "");
  double drop = 0.0;
  for (int c = 0; c < 3; ++c) drop += (sim.mesh->restPositions[3 * c + 1] - simulator.state().x[3 * c + 1]) / 3.0;
  const double expected = areal * kG * length * length / (2.0 * youngThickness);
  std::cout << GetParam() << ": bottom drops " << drop << " m (closed form " << expected << " m), "
            << quasiNewton << " L-BFGS iterations, " << fallbacks << " fallbacks\n";
  EXPECT_GT(quasiNewton, 0);
  EXPECT_NEAR(drop, expected, 0.02 * expected);
}

INSTANTIATE_TEST_SUITE_P(EveryMaterial, HangingStrip, ::testing::ValuesIn(materialNames()));

// A 9 x 9 cloth, 0.3 m square, let down flat 1.5 mm above a table top (contact distance
// dHat = 2 mm, friction 0.4, the barrier stiffness given as |g| = 9.81 m/s^2): the barrier force on
// a vertex of mass m at distance d is kappa m |b'(d^2)| 2 d, and kappa makes it m |g| at d = dHat/2
// (docs/contact.md), so every vertex of the flat cloth, its weight borne by its own barrier and
// no in-plane force, comes to rest at d = dHat/2 = 1 mm: z = 0.751 m. L-BFGS, with the barriers'
// and friction's blocks in its initial Hessian, converges in every substep without Newton and
// ends where Newton does (the bound of AgreesWithNewton).
SolvedRun clothOnTable(const std::string& solver, bool tight = true, double height = 0.0015, bool contactBlocks = true) {
  Scene scene = loadScene(std::string(FEM_CLOTH_CONFIG_DIR) + "/table_drape.yaml",
                          {"integrator.solver=" + solver, "integrator.lbfgs_max_iterations=10000",
                           "contact.stiffness=9.81", "contact.distance=0.002", "damping.mass=0"})
                    .value();
  scene.grid.rows = scene.grid.cols = 9;
  scene.grid.width = scene.grid.height = 0.3;
  scene.grid.origin = {-0.15, -0.15, 0.75 + height};
  if (tight) tightTolerance(scene);
  scene.integratorOptions.edit<ImplicitSolverSettings>("backward_euler").lbfgs.contact.traceInFactor = contactBlocks;
  Simulation sim = mustBuild(scene);
  Simulator& s = *sim.simulator;
  SolvedRun out;
  VectorX before = s.state().x;
  const std::string error = run(sim, 30, [&](int, const StepReport& r) { out.record(r, s, before); });
  EXPECT_EQ(error, "") << solver;
  out.x = s.state().x;
  return out;
}

// Every vertex within 1 % of the rest distance dHat/2 = 1 mm above the table top.
void expectRestingAtHalfTheContactDistance(const SolvedRun& r, const std::string& what) {
  const double rest = 0.75 + 0.5 * 0.002;
  double worst = 0.0;
  for (Index v = 0; v < r.x.size() / 3; ++v) worst = std::max(worst, std::abs(r.x[3 * v + 2] - rest));
  EXPECT_LT(worst, 1e-5) << what;
}

TEST(Contact, ClothRestsOnATableAtHalfTheContactDistance) {
  const SolvedRun newton = clothOnTable("newton"), lbfgs = clothOnTable("lbfgs");
  expectRestingAtHalfTheContactDistance(newton, "newton");
  expectRestingAtHalfTheContactDistance(lbfgs, "lbfgs");
  const double difference = worstVertex(newton.x, lbfgs.x), bound = 10.0 * 2.0 * lbfgs.tolerance;
  std::cout << "cloth on a table: Newton " << newton.newton << " iterations, L-BFGS " << lbfgs.quasiNewton
            << " iterations (" << lbfgs.fallbacks << " fallbacks); they differ by " << difference
            << " m, bound " << bound << " m\n";
  EXPECT_GT(lbfgs.quasiNewton, 0);
  EXPECT_EQ(lbfgs.fallbacks, 0);
  EXPECT_LE(difference, bound);
}

// The same cloth dropped from 5 mm above the table at the default tolerance: the contact blocks
// in B0 (trace / 3 on its diagonal, the default) save L-BFGS iterations against the B0 without
// them (measured: 131 against 141 over the 30 steps), and the cloth still comes to rest at dHat/2.
TEST(Contact, BlocksInTheInitialHessianSaveIterationsOnLanding) {
  const SolvedRun with = clothOnTable("lbfgs", false, 0.005, true), without = clothOnTable("lbfgs", false, 0.005, false);
  std::cout << "landing: L-BFGS " << with.quasiNewton << " iterations with the contact blocks ("
            << with.fallbacks << " fallbacks), " << without.quasiNewton << " without (" << without.fallbacks << ")\n";
  expectRestingAtHalfTheContactDistance(with, "with blocks");
  EXPECT_EQ(with.fallbacks, 0);
  EXPECT_LT(with.quasiNewton, without.quasiNewton);
}

namespace {

// config/flag.yaml (13 x 21 stvk cloth, bending 1e-5 N m, wind, backward Euler at dt 0.01) for
// 0.5 s at step dt with the scene keys `overrides`: the positions after every 0.01 s.
std::vector<VectorX> flagTrajectory(const std::vector<std::string>& overrides, int substepsPerStep = 1) {
  Scene scene = loadScene(std::string(FEM_CLOTH_CONFIG_DIR) + "/flag.yaml", overrides).value();
  scene.dt /= substepsPerStep;
  Simulation sim = mustBuild(scene);
  std::vector<VectorX> states;
  const std::string error = run(sim, 50 * substepsPerStep, [&](int k, const StepReport&) {
    if (k % substepsPerStep == 0) states.push_back(sim.simulator->state().x);
  });
  EXPECT_EQ(error, "");
  return states;
}

double rmsVertex(const VectorX& a, const VectorX& b) { return (a - b).norm() / std::sqrt(a.size() / 3.0); }

double worstOverStates(const std::vector<VectorX>& a, const std::vector<VectorX>& b) {
  double worst = 0.0;
  for (size_t k = 0; k < std::min(a.size(), b.size()); ++k) worst = std::max(worst, worstVertex(a[k], b[k]));
  return worst;
}

}  // namespace

// Issue 29: L-BFGS at the default tolerance is as right as Newton at it. Its own error estimate
// (the next L-BFGS step, B0 = the rest stiffness outside its pairs) understated the distance to
// the minimum about 100 x where the flag bends out of plane, and it ended 0.70 x backward
// Euler's own error from the converged trajectory (scripts/sameness); Newton's check of its
// solution now decides. Reference: Newton at the tight tolerance of scripts/sameness; backward
// Euler's own error: the reference against dt/8 at that tolerance; L-BFGS must be within 0.25 x
// that (the bound of item 1), at the end (RMS over vertices) and at the worst vertex of any step.
TEST(Acceptance, LbfgsOnTheFlagIsWithinAQuarterOfBackwardEulersOwnError) {
  const std::vector<std::string> tight = {"integrator.error_ratio=1e-4", "integrator.error_cap=1e-4",
                                          "integrator.error_floor=1e-9", "integrator.max_newton_iterations=500"};
  const std::vector<VectorX> reference = flagTrajectory(tight), fine = flagTrajectory(tight, 8);
  const std::vector<VectorX> lbfgs = flagTrajectory({"integrator.solver=lbfgs"});
  ASSERT_EQ(reference.size(), 50u);
  ASSERT_EQ(fine.size(), 50u);
  ASSERT_EQ(lbfgs.size(), 50u);
  const double ownEnd = rmsVertex(reference.back(), fine.back()), ownMax = worstOverStates(reference, fine);
  const double end = rmsVertex(reference.back(), lbfgs.back()), max = worstOverStates(reference, lbfgs);
  std::cout << "flag: backward Euler's own error " << ownEnd << " m RMS at the end, " << ownMax
            << " m at worst; L-BFGS " << end << " m (" << end / ownEnd << " x), " << max << " m (" << max / ownMax
            << " x)\n";
  EXPECT_GT(ownEnd, 1e-3);  // the flag moves: the comparison is not between zeros
  EXPECT_LE(end, 0.25 * ownEnd);
  EXPECT_LE(max, 0.25 * ownMax);
}

}  // namespace fem_cloth::test
