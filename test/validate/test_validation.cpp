// The physical validation (docs/validation.md) as tests: the references themselves against
// textbook limits (the elastica against beam theory and Peirce's 41.5 deg, the uniaxial closed
// forms against the formulas written in uniaxial.h), every case at 16 cells within its
// tolerance, and the validation failing when the simulated moduli are 5 % off. Plus the tool as
// a user runs it.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>

#include "../run_program.h"
#include "fem_cloth/core/materials/materials.h"
#include "fem_cloth/validate/cases.h"
#include "fem_cloth/validate/elastica.h"
#include "fem_cloth/validate/uniaxial.h"

using namespace fem_cloth;
using namespace fem_cloth::validate;

namespace {

constexpr double kPi = 3.14159265358979323846;

std::vector<CaseRow> mustRun(const std::string& name, const CaseOptions& options) {
  Expected<std::vector<CaseRow>> rows = runCase(name, options);
  EXPECT_TRUE(rows.ok()) << (rows.ok() ? "" : rows.error());
  return rows.ok() ? std::move(rows).value() : std::vector<CaseRow>{};
}

void expectAllPass(const std::vector<CaseRow>& rows) {
  ASSERT_FALSE(rows.empty());
  for (const CaseRow& r : rows) {
    EXPECT_TRUE(r.converged) << r.validation << " " << r.parameter << ": " << r.note;
    EXPECT_TRUE(r.pass()) << r.validation << " " << r.parameter << " " << r.quantity << ": error "
                          << r.error << " > " << r.tolerance;
  }
}

CaseOptions at(std::vector<int> cells) {
  CaseOptions o;
  o.cells = std::move(cells);
  return o;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// The references
// ---------------------------------------------------------------------------------------------

TEST(Elastica, SmallLoadsAreEulerBernoulli) {
  // w l^4 / (8 B) at the tip and the root moment w l^2 / 2: gamma / 8 and gamma / 2 per l.
  for (double gamma : {1e-4, 1e-3}) {
    const ElasticaSolution e = heavyElastica(gamma);
    ASSERT_TRUE(e.ok);
    EXPECT_NEAR(e.tipDrop / (gamma / 8), 1.0, 1e-6 + 0.1 * gamma);
    EXPECT_NEAR(e.rootCurvature / (gamma / 2), 1.0, 1e-6 + 0.1 * gamma);
  }
  EXPECT_EQ(heavyElastica(0.0).tipDrop, 0.0);
}

TEST(Elastica, PeircesFixedAngleAndItsInverse) {
  // ASTM D1388's fixed angle: c = l / 2, i.e. gamma = 8, where the chord is at 41.5 deg.
  const ElasticaSolution e = heavyElastica(8.0);
  ASSERT_TRUE(e.ok);
  EXPECT_NEAR(e.chordAngle * 180 / kPi, 41.5, 0.05);
  // Larger loads bend further, and the inverse finds the load back.
  EXPECT_GT(heavyElastica(9.0).chordAngle, e.chordAngle);
  EXPECT_NEAR(elasticaGammaForChordAngle(e.chordAngle), 8.0, 1e-6);
  EXPECT_NEAR(elasticaGammaForChordAngle(heavyElastica(20.0).chordAngle), 20.0, 1e-5);
  // The same from the tip drop; in the small-load limit the drop is gamma / 8 (beam theory).
  EXPECT_NEAR(elasticaGammaForTipDrop(heavyElastica(20.0).tipDrop), 20.0, 1e-5);
  EXPECT_NEAR(elasticaGammaForTipDrop(1e-4 / 8), 1e-4, 1e-8);
  EXPECT_NEAR(peirceBendingLength(1.962 * 8e-6, 1.962), 0.02, 1e-12);  // c = (B / w)^(1/3)
}

TEST(Uniaxial, ClosedFormsAtNuZero) {
  const double mu = 3.0, s = 1.17;
  EXPECT_NEAR(uniaxialAtStretch("stvk", mu, 0.0, s).stress, mu * (s * s - 1) * s, 1e-12);
  EXPECT_NEAR(uniaxialAtStretch("neo_hookean", mu, 0.0, s).stress, mu * (s - 1 / s), 1e-12);
  for (const char* m : {"linear", "corotational", "arap"}) {
    const UniaxialState u = uniaxialAtStretch(m, mu, 0.0, s);
    EXPECT_NEAR(u.stress, 2 * mu * (s - 1), 1e-12) << m;
    EXPECT_NEAR(u.transverse, 1.0, 1e-12) << m;
  }
  const double t = 2 * s / (1 + s * s);
  const UniaxialState snh = uniaxialAtStretch("stable_neo_hookean", mu, 0.0, s);
  EXPECT_NEAR(snh.transverse, t, 1e-12);
  EXPECT_NEAR(snh.stress, mu * (s - t) + mu * (s * t - 1) * t, 1e-12);
  EXPECT_NEAR(uniaxialAtStress("stvk", mu, 0.0, 0.5).stress, 0.5, 1e-12);
}

TEST(Uniaxial, PlaneStressYoungsModulusAndPoissonRatioAtSmallStrain) {
  const double E = 1e3, nu = 0.3, eps = 1e-6;
  const Lame lame = Lame::fromYoungPoisson(E, nu);
  for (const std::string& m : materialNames()) {
    const UniaxialState u = uniaxialAtStretch(m, lame.mu, lame.lambda, 1 + eps);
    // ARAP has no lambda: its uniaxial modulus is 2 mu = E / (1 + nu) and it does not contract.
    const bool arap = m == "arap";
    EXPECT_NEAR(u.stress / eps, arap ? E / (1 + nu) : E, 1e-3 * E) << m;
    EXPECT_NEAR((1 - u.transverse) / eps, arap ? 0.0 : nu, 1e-4) << m;
  }
}

// ---------------------------------------------------------------------------------------------
// The cases at 16 cells
// ---------------------------------------------------------------------------------------------

TEST(Validation, PeirceCantileverWithin3PercentOfTheElasticaAt16Cells) {
  CaseOptions o = at({16});
  o.gammas = {1, 8, 20};
  const std::vector<CaseRow> rows = mustRun("peirce", o);
  expectAllPass(rows);
  int tolerated = 0;
  for (const CaseRow& r : rows) tolerated += r.tolerance > 0 ? 1 : 0;
  // Per gamma the tip drop and the rigidity read back from it, at gamma 8 also the rigidity read
  // back from the tip angle; and the elastica's 41.5 deg.
  EXPECT_GE(tolerated, 8);
}

TEST(Validation, SimplySupportedPlateAt16CellsAndClampedPlateAt32) {
  expectAllPass(mustRun("plate_simply", at({16})));
  // Clamped: second-order convergence, +4.8 % at 16 cells (the 3 % target is missed there, see
  // docs/validation.md) and +1.2 % at 32.
  const std::vector<CaseRow> clamped = mustRun("plate_clamped", at({16, 32}));
  ASSERT_EQ(clamped.size(), 2u);
  EXPECT_LT(std::abs(clamped[1].error), 0.03);
  EXPECT_NEAR(convergenceOrder(clamped[0].error, 16, clamped[1].error, 32), 2.0, 0.2);
  EXPECT_TRUE(clamped[0].converged && clamped[1].converged);
}

namespace {

/// The classical finite-difference clamped-clamped beam: the 5-point stencil of w'''' = q / D on
/// n cells, w_0 = w_n = 0, the clamp as the mirrored ghost node w_-1 = w_1 (an independent
/// computation of the closure the midedge model's clamp plates amount to). Centre deflection
/// per q L^4 / D.
double finiteDifferenceClampedBeam(int n) {
  const double h = 1.0 / n;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n - 1, n - 1);
  const double stencil[5] = {1, -4, 6, -4, 1};
  for (int i = 1; i < n; ++i) {
    for (int k = -2; k <= 2; ++k) {
      int j = i + k;
      if (j == 0 || j == n) continue;  // w = 0 on the supports
      if (j == -1) j = 1;              // the mirrored ghost nodes
      if (j == n + 1) j = n - 1;
      A(i - 1, j - 1) += stencil[k + 2];
    }
  }
  const Eigen::VectorXd w = A.lu().solve(Eigen::VectorXd::Constant(n - 1, std::pow(h, 4)));
  return w[n / 2 - 1];
}

}  // namespace

TEST(Validation, TheClampIsTheMirroredGhostNodeOfTheFiniteDifferenceBeam) {
  // The clamped strip (cylindrical bending) comes out as the finite-difference beam with w_-1 =
  // w_1: the clamp holds dw/dn = 0 at the plate's edge, second order, +8/n^2 for this beam.
  const std::vector<CaseRow> rows = mustRun("beam_clamped", at({8, 16, 32}));
  ASSERT_EQ(rows.size(), 3u);
  for (const CaseRow& r : rows) {
    EXPECT_TRUE(r.converged) << r.cells;
    EXPECT_NEAR(r.value / finiteDifferenceClampedBeam(r.cells), 1.0, 0.002) << r.cells;
  }
  EXPECT_NEAR(finiteDifferenceClampedBeam(16) * 384, 1.0 + 8.0 / 256, 1e-9);
  EXPECT_LT(std::abs(rows[2].error), 0.01);
}

TEST(Validation, TheBeamDoesNotSeeTheDiagonalsAndThePlatesConvergeOnEachPattern) {
  // Cylindrical bending leaves every cell flat, so the diagonal's direction cannot matter: on
  // uniform diagonals the clamped strip is the same finite-difference beam (docs/validation.md,
  // "Why no clamp of this family reaches 3 % at 16 cells").
  CaseOptions uniform = at({8, 16});
  uniform.diagonals = "uniform";
  const std::vector<CaseRow> beam = mustRun("beam_clamped", uniform);
  ASSERT_EQ(beam.size(), 2u);
  for (const CaseRow& r : beam) {
    EXPECT_TRUE(r.converged) << r.cells;
    EXPECT_NEAR(r.value / finiteDifferenceClampedBeam(r.cells), 1.0, 0.002) << r.cells;
  }
  // Both plates converge at second order on both patterns of one diagonal per cell; the clamped
  // plate is as far off at 16 cells on either (+4.8 % and +4.7 %, the clamp's closure).
  uniform.cells = {16, 32};
  for (const char* name : {"plate_simply", "plate_clamped"}) {
    const std::vector<CaseRow> rows = mustRun(name, uniform);
    ASSERT_EQ(rows.size(), 2u);
    ASSERT_TRUE(rows[0].converged && rows[1].converged) << name;
    EXPECT_NEAR(convergenceOrder(rows[0].error, 16, rows[1].error, 32), 2.0, 0.2) << name;
  }
  EXPECT_GT(mustRun("plate_clamped", uniform)[0].error, 0.04);
  // The option does change the mesh: the simply supported plate's 16-cell error differs by more
  // than its 2e-10 solve residual between the patterns (+0.73 % alternating, -0.95 % uniform,
  // +0.35 % crossed).
  const double alternating = mustRun("plate_simply", at({16}))[0].error;
  EXPECT_GT(std::abs(mustRun("plate_simply", uniform)[0].error - alternating), 1e-3);
  // The crossed pattern (a vertex at each cell's centre) converges at second order where nothing
  // is clamped.
  CaseOptions crossed = at({16, 32});
  crossed.diagonals = "crossed";
  const std::vector<CaseRow> simply = mustRun("plate_simply", crossed);
  ASSERT_EQ(simply.size(), 2u);
  EXPECT_LT(std::abs(simply[0].error), 0.03);
  EXPECT_NEAR(convergenceOrder(simply[0].error, 16, simply[1].error, 32), 2.0, 0.3);
  EXPECT_GT(std::abs(simply[0].error - alternating), 1e-3);
  CaseOptions unknown = at({4});
  unknown.diagonals = "diamond";
  const Expected<std::vector<CaseRow>> bad = runCase("plate_simply", unknown);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("diamond"), std::string::npos) << bad.error();
}

TEST(Validation, ClampedPlateExtrapolatedFrom16And32CellsCatchesAFivePercentError) {
  // At 16 cells the clamped plate is +4.8 % (second order: docs/validation.md), which a 5 %
  // stiffer plate would hide (-0.2 %). Richardson's extrapolation of the second-order error from
  // 16 and 32 cells takes it out: within 0.5 % of Timoshenko's value, and -4.8 % when the plate
  // is 5 % stiffer.
  for (double scale : {1.0, 1.05}) {
    CaseOptions o = at({16, 32});
    o.modulusScale = scale;
    const std::vector<CaseRow> rows = mustRun("plate_clamped", o);
    ASSERT_EQ(rows.size(), 2u);
    ASSERT_TRUE(rows[0].converged && rows[1].converged);
    const double extrapolated = (4 * rows[1].value - rows[0].value) / 3;
    const double error = extrapolated / 0.00126532 - 1;  // Taylor & Govindjee (2004)
    if (scale == 1.0) {
      EXPECT_LT(std::abs(error), 0.005) << extrapolated;
    } else {
      EXPECT_LT(error, -0.03) << extrapolated;
    }
  }
}

TEST(Validation, MembraneCasesAt16Cells) {
  expectAllPass(mustRun("tension", at({16})));
  expectAllPass(mustRun("hanging_sheet", at({16})));
}

TEST(Validation, DynamicCases) {
  const std::vector<CaseRow> fall = mustRun("free_fall", at({16}));
  for (const CaseRow& r : fall) {
    // Backward Euler's own closed form: x_n = -g dt^2 n (n + 1) / 2, a relative error dt / T.
    if (r.parameter == "backward_euler") {
      EXPECT_NEAR(r.error, r.step / 0.4, 1e-6) << r.step;
    } else {
      EXPECT_LT(std::abs(r.error), 0.005) << r.parameter << " " << r.step;
    }
  }
  expectAllPass(mustRun("pendulum", at({16})));
  expectAllPass(mustRun("incline", at({16})));
}

TEST(Validation, CatchesAFivePercentErrorInAnyModulusOrStiffness) {
  CaseOptions stiff = at({16});
  stiff.modulusScale = 1.05;
  stiff.gammas = {1, 8, 20};
  for (const char* name : {"peirce", "plate_simply", "tension", "hanging_sheet"}) {
    // Every parameter (each gamma, each material) must see it, not just the case as a whole.
    std::map<std::string, bool> failed;
    for (const CaseRow& r : mustRun(name, stiff)) {
      if (r.tolerance > 0 && r.cells > 0) failed[r.parameter] = failed[r.parameter] || !r.pass();
    }
    EXPECT_FALSE(failed.empty()) << name;
    for (const auto& [parameter, seen] : failed) {
      EXPECT_TRUE(seen) << name << " " << parameter << " does not see moduli 5 % too large";
    }
  }
  // The clamped plate meets 3 % from 32 cells on (above): there it sees a 5 % stiffer plate.
  stiff.cells = {32};
  const std::vector<CaseRow> clamped = mustRun("plate_clamped", stiff);
  ASSERT_EQ(clamped.size(), 1u);
  EXPECT_TRUE(clamped[0].converged);
  EXPECT_GT(std::abs(clamped[0].error), 0.03);
}

// ---------------------------------------------------------------------------------------------
// The tool
// ---------------------------------------------------------------------------------------------

TEST(ValidateTool, PrintsTheTableAndWritesJsonAndCsv) {
  const test::TempDir dir("fem_cloth_validate");
  const std::string json = dir.path("rows.json"), csv = dir.path("rows.csv");
  const test::ProgramResult r = test::runProgram(
      FEM_CLOTH_VALIDATE_EXE, {"--case", "plate_simply", "--cells", "4,8", "--json", json, "--csv", csv}, dir);
  EXPECT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("plate_simply"), std::string::npos) << r.out;
  const nlohmann::json rows = nlohmann::json::parse(test::readTextFile(json));
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1]["cells"], 8);
  EXPECT_NEAR(rows[1]["reference"].get<double>(), 0.00406, 5e-6);  // Timoshenko's table 8
  EXPECT_TRUE(rows[1]["order"].is_number());
  EXPECT_NE(test::readTextFile(csv).find("validation,parameter,cells"), std::string::npos);
  const test::ProgramResult bad = test::runProgram(FEM_CLOTH_VALIDATE_EXE, {"--case", "plate"}, dir);
  EXPECT_EQ(bad.status, 2);
  EXPECT_NE((bad.out + bad.err).find("plate"), std::string::npos);
  const test::ProgramResult pattern =
      test::runProgram(FEM_CLOTH_VALIDATE_EXE, {"--case", "plate_simply", "--diagonals", "diamond"}, dir);
  EXPECT_EQ(pattern.status, 2);
  EXPECT_NE((pattern.out + pattern.err).find("diamond"), std::string::npos) << pattern.out << pattern.err;
  const test::ProgramResult help = test::runProgram(FEM_CLOTH_VALIDATE_EXE, {"--help"}, dir);
  EXPECT_EQ(help.status, 0);
  EXPECT_NE(help.out.find("--cells"), std::string::npos);
}
