// Projective dynamics: converged, it is backward Euler on the ARAP membrane (compared with the
// Newton solver, which is tested on its own); pins are exact; what it cannot simulate is refused
// with a clear error; the pins carry the cloth's weight at rest.
#include <gtest/gtest.h>

#include <iostream>
#include <limits>

#include "fem_cloth/io/scene_yaml.h"

using namespace fem_cloth;

namespace {

const std::string kScene = std::string(FEM_CLOTH_SOURCE_DIR) + "/config/hanging_cloth.yaml";

Expected<Simulation> build(const std::vector<std::string>& overrides) {
  Expected<Scene> scene = loadScene(kScene, overrides);
  if (!scene) return Error{scene.error()};
  return buildSimulation(*scene);
}

std::vector<std::string> arap(const std::string& integrator, std::vector<std::string> more = {}) {
  std::vector<std::string> o = {"mesh.rows=9", "mesh.cols=9", "material.model=arap",
                                "integrator.name=" + integrator, "damping.mass=0.5"};
  o.insert(o.end(), more.begin(), more.end());
  return o;
}

}  // namespace

// One step each from the same state: both minimise the same incremental potential, PD by its
// monotone local/global iteration, backward Euler by Newton (to a tight tolerance).
static double gapAfterOneStep(const std::string& dt, int iterations) {
  Expected<Simulation> pd = build(arap("projective_dynamics", {"integrator.dt=" + dt, "integrator.iterations=" + std::to_string(iterations)}));
  Expected<Simulation> be = build(arap("backward_euler", {"integrator.dt=" + dt, "integrator.error_ratio=1e-6",
                                                           "integrator.error_cap=1e-6", "integrator.error_floor=1e-12"}));
  EXPECT_TRUE(pd.ok() && be.ok());
  EXPECT_TRUE(pd->simulator->step().ok);
  EXPECT_TRUE(be->simulator->step().ok);
  // The step did move the cloth (it falls by at least g dt^2 / 2).
  EXPECT_GT((be->simulator->state().x - be->mesh->restPositions).cwiseAbs().maxCoeff(), 4e-4);
  return (pd->simulator->state().x - be->simulator->state().x).cwiseAbs().maxCoeff();
}

TEST(ProjectiveDynamics, ConvergedItIsBackwardEulerOnArap) {
  // At dt = 0.01 s PD reaches backward Euler's step to round-off.
  EXPECT_LT(gapAfterOneStep("0.01", 20000), 1e-10);
  // PD converges linearly, more slowly for larger steps: at dt = 1/30 s, 4e4 iterations bring
  // the gap down by two orders of magnitude from 1e4 iterations (far more than a real step uses).
  const double coarse = gapAfterOneStep("0.03333333333333333", 10000);
  const double fine = gapAfterOneStep("0.03333333333333333", 40000);
  EXPECT_LT(fine, 1e-2 * coarse);
  EXPECT_LT(fine, 1e-8);
}

// A fixed number of iterations per step (acceptance test (a) off, so that PD stops at that
// count, as it did before issue 11): the error against the converged step shrinks as the count
// grows (each local/global iteration lowers the incremental potential, Bouaziz et al. 2014). With
// the test on (the default), PD iterates on until its error in displacement is within the test:
// from any starting count, with every step's error measured and within its bound, it ends within
// a quarter of backward Euler's own error (the converged steps at dt against dt/8) of the
// converged step, which is what the test's default error_ratio 0.1 promises (docs/integrators.md).
namespace {

Simulation withFixedIterations(int iterations, const std::string& dt = "0.01") {
  Expected<Simulation> sim = build(arap("projective_dynamics", {"integrator.dt=" + dt}));
  EXPECT_TRUE(sim.ok());
  ProjectiveDynamicsSettings settings;
  settings.iterations = settings.maxIterations = iterations;
  SimulatorSettings simulatorSettings = sim->simulator->settings();
  simulatorSettings.acceptance.forceTolerance = std::numeric_limits<double>::infinity();
  simulatorSettings.acceptance.displacement.ratio = std::numeric_limits<double>::infinity();
  simulatorSettings.acceptance.displacement.cap = std::numeric_limits<double>::infinity();
  sim->simulator = std::make_unique<Simulator>(sim->model, std::make_unique<ProjectiveDynamics>(settings),
                                               simulatorSettings);
  for (Index v : {0, 8}) EXPECT_TRUE(sim->simulator->pinInPlace(v).ok());
  return std::move(sim).value();
}

}  // namespace

TEST(ProjectiveDynamics, FewerIterationsAreSofterButConvergeMonotonically) {
  Simulation reference = withFixedIterations(3000);
  for (int k = 0; k < 10; ++k) ASSERT_TRUE(reference.simulator->step().ok);
  Simulation fine = withFixedIterations(3000, "0.00125");
  for (int k = 0; k < 80; ++k) ASSERT_TRUE(fine.simulator->step().ok);
  const double schemeError = (fine.simulator->state().x - reference.simulator->state().x).norm();
  double previous = 1e300, fixed32 = 0.0;
  for (int iterations : {2, 8, 32, 128}) {
    Simulation pd = withFixedIterations(iterations);
    for (int k = 0; k < 10; ++k) ASSERT_TRUE(pd.simulator->step().ok);
    const double error = (pd.simulator->state().x - reference.simulator->state().x).norm();
    EXPECT_LT(error, previous) << iterations << " iterations";
    previous = error;
    if (iterations == 32) fixed32 = error;
  }
  for (int iterations : {2, 8, 32}) {
    Expected<Simulation> pd = build(arap("projective_dynamics", {"integrator.iterations=" + std::to_string(iterations)}));
    ASSERT_TRUE(pd.ok());
    for (int k = 0; k < 10; ++k) {
      const StepReport r = pd->simulator->step();
      ASSERT_TRUE(r.ok) << r.error;
      EXPECT_TRUE(r.displacement.measured());
      EXPECT_LE(r.displacement.relative, 1.0);
    }
    const double error = (pd->simulator->state().x - reference.simulator->state().x).norm();
    std::cout << "from " << iterations << " iterations on: error " << error << " (32 fixed: " << fixed32
              << "; backward Euler's own error " << schemeError << ")\n";
    EXPECT_LT(error, 0.25 * schemeError) << iterations << " iterations";
  }
}

TEST(ProjectiveDynamics, PinsAreExactAndCarryTheWeightAtRest) {
  Expected<Simulation> pd = build(arap("projective_dynamics", {"damping.mass=5", "integrator.iterations=50"}));
  ASSERT_TRUE(pd.ok());
  Simulator& sim = *pd->simulator;
  for (int k = 0; k < 600; ++k) ASSERT_TRUE(sim.step().ok);
  // Pinned corners (vertices 0 and 8) exactly at rest positions.
  EXPECT_EQ(sim.state().x.segment<3>(0), pd->mesh->restPositions.segment<3>(0));
  EXPECT_EQ(sim.state().x.segment<3>(24), pd->mesh->restPositions.segment<3>(24));
  // At rest the pins carry the weight: 1 kg x 9.81 m/s^2 pulling down.
  const VectorX reactions = sim.pinReactions();
  double fz = 0.0;
  for (Index v : sim.pinnedVertices()) fz += reactions[3 * v + 2];
  // Nearly at rest: kinetic energy K below 1e-6 J bounds the damping drag alpha M v by
  // 5 /s x sqrt(2 M K) = 7e-3 N, under the 1 % allowed.
  EXPECT_LT(sim.energies().kinetic, 1e-6);
  EXPECT_NEAR(fz, -9.81, 0.01 * 9.81);
}

TEST(ProjectiveDynamics, RefusesWhatItCannotSimulateWhenTheSceneIsLoaded) {
  // Each scene below differs from a good one in one key; the error names that key.
  auto refusal = [](const std::vector<std::string>& overrides) {
    Expected<Simulation> sim = build(overrides);
    return sim.ok() ? std::string() : sim.error();
  };
  ASSERT_EQ(refusal(arap("projective_dynamics")), "");
  const std::string stvk = refusal({"mesh.rows=5", "mesh.cols=5", "integrator.name=projective_dynamics",
                                    "material.model=stvk"});
  EXPECT_NE(stvk.find("material.model"), std::string::npos) << stvk;
  EXPECT_NE(stvk.find("'stvk'"), std::string::npos) << stvk;
  const std::string damped = refusal(arap("projective_dynamics", {"damping.stiffness=0.01"}));
  EXPECT_NE(damped.find("damping.stiffness"), std::string::npos) << damped;
  const std::string dihedral =
      refusal(arap("projective_dynamics", {"bending.stiffness=1e-4", "bending.model=dihedral"}));
  EXPECT_NE(dihedral.find("bending.model"), std::string::npos) << dihedral;
  const std::string planar = refusal(arap("projective_dynamics", {"mesh.dim=2", "gravity=[0, 0, 0]"}));
  EXPECT_NE(planar.find("mesh.dim"), std::string::npos) << planar;
}
