// The measuring side of the accuracy report: error measures and orders against hand
// calculations, the sample grid against backward Euler's closed-form free fall, the reference
// cache, the classification of stability cells, and the recorded grasp re-applied exactly as the
// node applied it.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "../temp_dir.h"
#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/report/cases.h"
#include "fem_cloth/report/run.h"
#include "fem_cloth/report/stability.h"
#include "fem_cloth/ros/bag_io.h"
#include "fem_cloth/ros/bag_replay.h"

using namespace fem_cloth;
using namespace fem_cloth::report;

namespace {

// A 3 x 3 cloth falling freely (no pins, no damping, no elastic force at rest: it stays flat and
// unstrained), backward Euler.
YAML::Node fallingCloth(double dt, double duration) {
  YAML::Node doc;
  doc["name"] = "fall";
  doc["mesh"]["type"] = "grid";
  doc["mesh"]["rows"] = 3;
  doc["mesh"]["cols"] = 3;
  doc["material"]["model"] = "stvk";
  doc["material"]["youngs_modulus"] = 2e7;
  doc["material"]["poisson_ratio"] = 0.3;
  doc["integrator"]["name"] = "backward_euler";
  doc["integrator"]["dt"] = dt;
  doc["duration"] = duration;
  return doc;
}

}  // namespace

TEST(PositionErrors, MatchAHandCalculation) {
  // Two vertices in 3D; cloth size 10 m. Sample 0: identical. Sample 1: vertex 0 off by
  // (3, 4, 0) (distance 5), vertex 1 exact: RMS = sqrt(25 / 2), max = 5.
  VectorX a(6), b(6);
  a << 0, 0, 0, 1, 1, 1;
  b = a;
  VectorX c = a;
  c.head(3) += Eigen::Vector3d(3, 4, 0);
  const PositionErrors e = positionErrors({a, c}, {b, b}, 3, 10.0);
  ASSERT_EQ(e.rms.size(), 2u);
  EXPECT_DOUBLE_EQ(e.rms[0], 0.0);
  EXPECT_DOUBLE_EQ(e.max[0], 0.0);
  EXPECT_NEAR(e.rms[1], std::sqrt(12.5) / 10.0, 1e-15);
  EXPECT_NEAR(e.max[1], 0.5, 1e-15);
  EXPECT_DOUBLE_EQ(e.rmsEnd, e.rms[1]);
  EXPECT_DOUBLE_EQ(e.maxOverTime, 0.5);
  // A run that stopped early is compared on the samples it has.
  const PositionErrors shorter = positionErrors({c}, {b, b}, 3, 10.0);
  EXPECT_EQ(shorter.rms.size(), 1u);
}

TEST(FittedOrder, RecoversThePowerOfExactData) {
  const std::vector<double> dts = {0.1, 0.05, 0.025, 0.0125};
  for (double p : {0.5, 1.0, 1.7, 2.0}) {
    std::vector<double> e;
    for (double dt : dts) e.push_back(3.0 * std::pow(dt, p));
    EXPECT_NEAR(fittedOrder(dts, e), p, 1e-12) << p;
  }
  // Zero or non-finite errors are left out; fewer than two points give NaN.
  EXPECT_NEAR(fittedOrder({0.1, 0.05, 0.025}, {0.0, 0.5, 0.25}), 1.0, 1e-12);
  EXPECT_TRUE(std::isnan(fittedOrder({0.1}, {1.0})));
}

// Backward Euler's free fall from rest: v_n = -g h n, x_n = x_0 - g h^2 n (n + 1) / 2. The
// samples must sit at t = k * sampleInterval exactly.
TEST(RunScene, SamplesOnTheTimeGrid) {
  RunRequest request;
  request.scene = fallingCloth(0.01, 0.1);
  request.sampleInterval = 0.02;
  const RunResult r = runScene(request);
  ASSERT_EQ(r.outcome, RunResult::Outcome::Completed) << r.error;
  ASSERT_EQ(r.samples.size(), 6u);
  EXPECT_EQ(r.steps, 10u);
  const double g = 9.81, h = 0.01;
  for (std::size_t k = 0; k < r.samples.size(); ++k) {
    const double n = 2.0 * static_cast<double>(k);
    EXPECT_NEAR(r.sampleTimes[k], 0.02 * k, 1e-12);
    for (Index i = 0; i < 9; ++i) {
      EXPECT_NEAR(r.samples[k][3 * i + 2], -g * h * h * n * (n + 1) / 2, 1e-9) << k;
    }
  }
  EXPECT_NEAR(r.clothSize, std::sqrt(2.0), 1e-12);
  EXPECT_GT(r.wall, 0.0);
  // Nothing is stretched; backward Euler's balance error is its (negative) numerical damping.
  EXPECT_LT(r.maxStretch, 1e-9);
  EXPECT_LE(r.energyGrowth, 1e-9);
}

TEST(RunScene, RefusesAStepThatDoesNotDivideTheSampleInterval) {
  RunRequest request;
  request.scene = fallingCloth(0.03, 0.12);
  request.sampleInterval = 0.04;
  const RunResult r = runScene(request);
  EXPECT_EQ(r.outcome, RunResult::Outcome::BuildError);
  EXPECT_NE(r.error.find("does not divide"), std::string::npos) << r.error;
  EXPECT_TRUE(wholeSteps(0.1, 1.0 / 30.0));
  EXPECT_FALSE(wholeSteps(0.15, 1.0 / 30.0));
}

TEST(RunScene, ABadSceneIsABuildErrorNamingTheKey) {
  RunRequest request;
  request.scene = fallingCloth(0.01, 0.1);
  request.scene["material"]["poisson_ratio"] = 0.7;
  const RunResult r = runScene(request);
  EXPECT_EQ(r.outcome, RunResult::Outcome::BuildError);
  EXPECT_NE(r.error.find("poisson_ratio"), std::string::npos) << r.error;
}

TEST(CachedReference, StoresReadsBackAndKeysOnTheSceneText) {
  const test::TempDir dir("fem_cloth_report_cache");
  RunRequest request;
  request.scene = fallingCloth(0.01, 0.1);
  request.duration = 0.1;
  request.sampleInterval = 0.05;
  Expected<Reference> first = cachedReference(request, "", dir.path("cache"));
  ASSERT_TRUE(first.ok()) << first.error();
  EXPECT_FALSE(first->cached);
  Expected<Reference> again = cachedReference(request, "", dir.path("cache"));
  ASSERT_TRUE(again.ok()) << again.error();
  EXPECT_TRUE(again->cached);
  EXPECT_EQ(again->key, first->key);
  ASSERT_EQ(again->run.samples.size(), first->run.samples.size());
  for (std::size_t k = 0; k < first->run.samples.size(); ++k) {
    EXPECT_EQ(again->run.samples[k], first->run.samples[k]);  // bit for bit
    EXPECT_EQ(again->run.sampleTimes[k], first->run.sampleTimes[k]);
  }
  EXPECT_EQ(again->run.clothSize, first->run.clothSize);
  // Another scene text is another reference.
  request.scene["integrator"]["dt"] = 0.005;
  Expected<Reference> other = cachedReference(request, "", dir.path("cache"));
  ASSERT_TRUE(other.ok()) << other.error();
  EXPECT_FALSE(other->cached);
  EXPECT_NE(other->key, first->key);
}

// The recorded grasp-and-lift re-applied through the node's driver at the recorded step gives
// the recorded final state bit for bit: the report drives every integrator with exactly the
// commands the node applied.
TEST(RunScene, RecordedGraspIsReappliedExactly) {
  Expected<RecordedRun> run = readRun(FEM_CLOTH_GRASP_BAG);
  ASSERT_TRUE(run.ok()) << run.error();
  ASSERT_FALSE(run->states.empty());
  const YAML::Node scene = YAML::Load(run->sceneYaml);
  const double dt = scene["integrator"]["dt"].as<double>();
  const RecordedState& last = run->states.back();
  RunRequest request;
  request.scene = scene;
  Expected<std::shared_ptr<const Recording>> recording = readRecording(FEM_CLOTH_GRASP_BAG);
  ASSERT_TRUE(recording.ok()) << recording.error();
  request.commands = *recording;
  request.recordedDt = dt;
  request.duration = static_cast<double>(last.step) * dt;
  const RunResult r = runScene(request);
  ASSERT_EQ(r.outcome, RunResult::Outcome::Completed) << r.error;
  EXPECT_EQ(r.steps, last.step);
  EXPECT_EQ(r.finalHash, last.hash);
}

TEST(ExtremeCases, BuildAndSayWhatTheyAre) {
  for (const std::string& name : extremeCaseNames()) {
    Expected<YAML::Node> doc = extremeCase(name, 9);
    ASSERT_TRUE(doc.ok()) << name << ": " << doc.error();
    Expected<Scene> scene = parseScene(*doc);
    ASSERT_TRUE(scene.ok()) << name << ": " << scene.error();
    EXPECT_TRUE(buildSimulation(*scene).ok()) << name;
    EXPECT_NE(extremeCaseDescription(name), name);
    // Every horizon is a whole number of every step of the matrix.
    for (double dt : stabilityDts()) EXPECT_TRUE(wholeSteps(scene->duration, dt)) << name << " " << dt;
  }
  EXPECT_FALSE(extremeCase("nothing", 9).ok());
  EXPECT_FALSE(extremeCase("whip", 8).ok());
}

// The geometry each case promises, measured here from its scene.
TEST(ExtremeCases, GeometryIsAsDescribed) {
  // inverted: the left half of the sheet mirrored, so its triangles have J = -1 exactly and the
  // right half's J = +1.
  {
    Expected<Scene> scene = parseScene(*extremeCase("inverted", 9));
    ASSERT_TRUE(scene.ok());
    Simulation sim = std::move(buildSimulation(*scene)).value();
    int inverted = 0;
    for (Index t = 0; t < sim.mesh->numTriangles(); ++t) {
      const double J = triangleArea(*sim.mesh, sim.simulator->state().x, t, true) /
                       triangleArea(*sim.mesh, sim.mesh->restPositions, t, true);
      EXPECT_NEAR(std::abs(J), 1.0, 1e-12);
      inverted += J < 0.0;
    }
    EXPECT_EQ(inverted, sim.mesh->numTriangles() / 2);
  }
  // degenerate: slivers of quality ~1e-5 in the rest mesh, every triangle valid. Vertex (2, 2)
  // lands next to the grid line of row 1, which flattens its two triangles on that line; vertex
  // (4, 5) lands next to a diagonal, which flattens one.
  {
    Expected<Scene> scene = parseScene(*extremeCase("degenerate", 9));
    ASSERT_TRUE(scene.ok());
    Simulation sim = std::move(buildSimulation(*scene)).value();
    int slivers = 0;
    for (Index t = 0; t < sim.mesh->numTriangles(); ++t) {
      const double q = triangleQuality(*sim.mesh, t);
      EXPECT_GT(q, 1e-6);
      slivers += q < 1e-4;
    }
    EXPECT_EQ(slivers, 3);
  }
  // squash: the boundary reaches the centre at t = 0.1 s; pull_corner: the corner moves 5 m.
  {
    Expected<Scene> scene = parseScene(*extremeCase("squash", 9));
    ASSERT_TRUE(scene.ok());
    for (const ScenePin& p : scene->pins) {
      ASSERT_EQ(p.select.vertices.size(), 1u);
      const Index v = p.select.vertices[0];
      const Eigen::Vector2d rest((v % 9) / 8.0, (v / 9) / 8.0);
      EXPECT_NEAR((rest + 0.1 * p.velocity.head<2>() - Eigen::Vector2d(0.5, 0.5)).norm(), 0.0, 1e-12);
      EXPECT_DOUBLE_EQ(p.releaseAt, 0.1);
    }
    Expected<Scene> pull = parseScene(*extremeCase("pull_corner", 9));
    ASSERT_TRUE(pull.ok());
    EXPECT_NEAR(pull->pins[1].velocity.norm() * pull->pins[1].releaseAt, 5.0, 1e-12);
    Expected<Scene> whip = parseScene(*extremeCase("whip", 9));
    ASSERT_TRUE(whip.ok());
    EXPECT_NEAR(whip->pins[0].velocity.norm(), 100.0, 1e-12);
  }
}

TEST(StabilityCell, ClassifiesAndKeepsTheError) {
  // A gentle cell is stable.
  const CellResult ok = runCell(Cell{"whip", "stvk", "cotton", "backward_euler", 1e-2}, 5, 60.0);
  EXPECT_EQ(ok.verdict, "stable") << ok.run.error;
  EXPECT_EQ(ok.run.rollbacks, 0u);
  // Neo-Hookean cannot start inverted: the case does not build with any integrator, so the cell
  // failed (not "n/a"), with the scene error.
  const CellResult refused = runCell(Cell{"inverted", "neo_hookean", "cotton", "xpbd", 1e-2}, 5, 60.0);
  EXPECT_EQ(refused.verdict, "failed");
  EXPECT_EQ(refused.run.outcome, RunResult::Outcome::BuildError);
  EXPECT_NE(refused.run.error.find("outside the material's domain"), std::string::npos)
      << refused.run.error;
  // A budget too small to finish: too_slow, with where it stopped.
  const CellResult slow = runCell(Cell{"whip", "stvk", "cotton", "backward_euler", 1e-4}, 5, 1e-9);
  EXPECT_EQ(slow.verdict, "too_slow");
  EXPECT_NE(slow.run.error.find("stopped after"), std::string::npos) << slow.run.error;
}

// "wrong": accepted, but the result is not right. A StVK strip under T = 200 N/m in uniaxial
// plane stress: the transverse stress vanishes, so S11 = 4 mu (lambda + mu) / (lambda + 2 mu) E11
// = E h E11 with the plane-stress moduli, and the nominal stress s1 S11 = E h s1 (s1^2 - 1) / 2
// equals T: s1 (s1^2 - 1) = 2 T / (E h) = 0.04, solved here by Newton.
TEST(StabilityCell, WrongWhenTheStripMissesItsClosedFormOrEnergyWasCreated) {
  using S = StripCase;
  double s1 = 1.0;
  for (int k = 0; k < 50; ++k) s1 -= (s1 * (s1 * s1 - 1.0) - 0.04) / (3.0 * s1 * s1 - 1.0);
  auto stretched = [](double axial) {
    VectorX x(3 * S::rows * S::cols);
    for (int r = 0; r < S::rows; ++r) {
      for (int c = 0; c < S::cols; ++c) {
        x.segment<3>(3 * (r * S::cols + c)) << axial * c * S::length / (S::cols - 1),
            r * S::width / (S::rows - 1), 0.0;
      }
    }
    return x;
  };
  const Cell cell{"strip", "stvk", "cotton", "backward_euler", 1e-2};
  RunResult run;
  auto why = [&](const Cell& c) {
    const Status status = checkCompleted(c, run);
    return status.ok() ? std::string("right") : status.error();
  };
  run.samples = {stretched(1.0), stretched(s1)};
  EXPECT_EQ(why(cell), "right");
  // At rest while pulled: shorter than (not longer than) at rest.
  run.samples.back() = stretched(1.0);
  EXPECT_NE(why(cell).find("shorter than at rest"), std::string::npos) << why(cell);
  // 10 % of the strain off the closed form (wrong), and 3 % (right).
  run.samples.back() = stretched(1.0 + 0.9 * (s1 - 1.0));
  EXPECT_NE(why(cell).find("uniaxial closed form"), std::string::npos) << why(cell);
  run.samples.back() = stretched(1.0 + 1.03 * (s1 - 1.0));
  EXPECT_EQ(why(cell), "right");
  // The right state, but 10 % of the energy scale created: wrong, in any case.
  run.energyGrowth = 0.1;
  EXPECT_NE(why(cell).find("created 10 %"), std::string::npos) << why(cell);
  EXPECT_NE(why(Cell{"whip", "stvk", "cotton", "backward_euler", 1e-2}).find("created 10 %"), std::string::npos);
  run.energyGrowth = 0.01;
  EXPECT_EQ(why(Cell{"whip", "stvk", "cotton", "backward_euler", 1e-2}), "right");
}

TEST(WorkPrecisionVariants, EveryIntegratorIsIncludedWithItsSettings) {
  const std::vector<Variant> variants = workPrecisionVariants(integratorNames(), false);
  for (const std::string& name : integratorNames()) {
    int count = 0;
    for (const Variant& v : variants) {
      if (v.integrator != name) continue;
      ++count;
      // Every variant must be a valid scene on the standard scene (its ARAP version for
      // projective dynamics, which takes nothing else).
      std::vector<std::string> overrides = v.overrides;
      if (name == "projective_dynamics") overrides.insert(overrides.begin(), "material.model=arap");
      Expected<Scene> scene = loadScene(std::string(FEM_CLOTH_CONFIG_DIR) + "/hanging_cloth.yaml", overrides);
      EXPECT_TRUE(scene.ok()) << v.label << ": " << scene.error();
      if (scene) {
        EXPECT_EQ(scene->integrator, name);
      }
    }
    EXPECT_GE(count, 2) << name;
  }
  // An integrator the report does not know gets iteration counts (the key every iterative
  // solver of the scene format reads).
  const std::vector<Variant> unknown = workPrecisionVariants({"future_solver"}, false);
  ASSERT_FALSE(unknown.empty());
  EXPECT_NE(unknown.back().overrides.back().find("integrator.iterations="), std::string::npos);
}
