// The performance properties the benchmarks rely on, asserted (never timed):
//  - a steady-state step allocates nothing on the heap (fast path, explicit, XPBD);
//  - parallel element work gives bit-identical results for any number of threads;
//  - sparsity pattern, symbolic analysis and factorisation are built once per topology (and,
//    for projective dynamics, once per set of pinned vertices).
#include <gtest/gtest.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "../allocation_counter.h"
#include "fem_cloth/core/bending.h"
#include "fem_cloth/core/integrators/implicit.h"
#include "fem_cloth/core/integrators/projective_dynamics.h"
#include "fem_cloth/core/membrane.h"
#include "fem_cloth/io/scene_yaml.h"

using namespace fem_cloth;
using fem_cloth::test::allocationCount;

namespace {

const std::string kScene = std::string(FEM_CLOTH_SOURCE_DIR) + "/config/hanging_cloth.yaml";

Simulation simulation(const std::vector<std::string>& overrides) {
  Expected<Scene> scene = loadScene(kScene, overrides);
  EXPECT_TRUE(scene.ok()) << scene.error();
  Expected<Simulation> sim = buildSimulation(*scene);
  EXPECT_TRUE(sim.ok()) << sim.error();
  return std::move(sim).value();
}

// A state hash of positions and velocities (FNV-1a over the bits), computed here.
std::uint64_t bitsHash(const State& s) {
  std::uint64_t h = 14695981039346656037ull;
  for (const VectorX* v : {&s.x, &s.v}) {
    const auto* b = reinterpret_cast<const unsigned char*>(v->data());
    for (std::size_t i = 0; i < static_cast<std::size_t>(v->size()) * sizeof(double); ++i) {
      h = (h ^ b[i]) * 1099511628211ull;
    }
  }
  return h;
}

}  // namespace

class SteadyState : public testing::TestWithParam<std::vector<std::string>> {};

TEST_P(SteadyState, StepsAllocateNothing) {
#ifdef FEM_CLOTH_COUNT_ALLOCATIONS
  Simulation sim = simulation(GetParam());
  // Warm up: factorisations, the stability bound, buffers sized on first use.
  for (int k = 0; k < 30; ++k) ASSERT_TRUE(sim.simulator->step().ok);
  const long before = allocationCount.load();
  // 25 steps include a re-estimate of symplectic Euler's bound (every 20 steps).
  for (int k = 0; k < 25; ++k) sim.simulator->step();
  EXPECT_EQ(allocationCount.load() - before, 0) << GetParam()[0];
  // A scene with obstacles was in contact throughout (else it proves nothing about contact).
  if (sim.simulator->contact() != nullptr) {
    EXPECT_GT(sim.simulator->lastReport().contacts, 0);
  }
  // The counter does see allocations.
  const long check = allocationCount.load();
  void* volatile probe = std::malloc(64);
  std::free(probe);
  EXPECT_EQ(allocationCount.load() - check, 1);
#else
  GTEST_SKIP() << "allocation counting needs glibc";
#endif
}

INSTANTIATE_TEST_SUITE_P(
    FastExplicitXpbdAndNewton, SteadyState,
    testing::Values(
        std::vector<std::string>{"integrator.name=projective_dynamics", "material.model=arap",
                                 "mesh.rows=17", "mesh.cols=17", "bending.stiffness=1e-5",
                                 "bending.model=quadratic"},
        std::vector<std::string>{"integrator.name=symplectic_euler", "mesh.rows=9", "mesh.cols=9"},
        std::vector<std::string>{"integrator.name=xpbd", "integrator.substeps=4", "mesh.rows=9",
                                 "mesh.cols=9"},
        // Backward Euler's Newton solve with contact and friction: the cloth lying on a table
        // 5 mm below it, inside the barrier's 10 mm from the start (barriers, CCD, lagged
        // friction at every iteration).
        std::vector<std::string>{"integrator.name=backward_euler", "mesh.rows=9", "mesh.cols=9",
                                 "contact.distance=0.01",
                                 "obstacles=[{name: table, type: box, center: [0.5, 0.5, -0.505], "
                                 "size: [2.0, 2.0, 1.0], friction: 0.3}]"}));

TEST(Parallel, ElementWorkIsBitIdenticalForAnyThreadCount) {
#ifdef _OPENMP
  // 65 x 65: 8192 triangles, above the threshold for parallel element loops.
  Simulation sim = simulation({"mesh.rows=65", "mesh.cols=65", "material.model=corotational"});
  Model& model = *sim.model;
  VectorX x = sim.mesh->restPositions;
  for (Eigen::Index i = 0; i < x.size(); ++i) x[i] += 1e-3 * std::sin(0.37 * static_cast<double>(i));
  auto evaluate = [&](int threads, VectorX& g, std::vector<double>& h) {
    omp_set_num_threads(threads);
    SparseHessian& H = model.hessianPattern();
    H.setZero();
    g.setZero(x.size());
    EvalRequest r;
    r.gradient = &g;
    r.hessian = &H;
    const double e = model.evaluate(x, r).energy;
    h.assign(H.values(), H.values() + H.matrix().nonZeros());
    return e;
  };
  VectorX g1, g2;
  std::vector<double> h1, h2;
  const double e1 = evaluate(1, g1, h1);
  const double e2 = evaluate(2, g2, h2);
  omp_set_num_threads(omp_get_num_procs());
  EXPECT_EQ(e1, e2);
  EXPECT_EQ(g1, g2);
  EXPECT_TRUE(h1 == h2);
#else
  GTEST_SKIP() << "built without OpenMP";
#endif
}

TEST(Parallel, ProjectiveDynamicsRunIsBitIdenticalForAnyThreadCount) {
#ifdef _OPENMP
  auto run = [](int threads) {
    omp_set_num_threads(threads);
    Simulation sim = simulation({"integrator.name=projective_dynamics", "material.model=arap",
                                 "mesh.rows=65", "mesh.cols=65", "integrator.dt=0.016666666666666666",
                                 "integrator.iterations=3"});
    for (int k = 0; k < 5; ++k) sim.simulator->step();
    return bitsHash(sim.simulator->state());
  };
  const std::uint64_t one = run(1), two = run(2);
  omp_set_num_threads(omp_get_num_procs());
  EXPECT_EQ(one, two);
#else
  GTEST_SKIP() << "built without OpenMP";
#endif
}

TEST(Factorisation, ImplicitSolverAnalysesThePatternOnce) {
  Simulation sim = simulation({"integrator.name=backward_euler", "mesh.rows=9", "mesh.cols=9"});
  for (int k = 0; k < 20; ++k) ASSERT_TRUE(sim.simulator->step().ok);
  // Pins come and go: the pattern stays (pinned rows are filtered, not removed).
  ASSERT_TRUE(sim.simulator->release(0).ok());
  for (int k = 0; k < 10; ++k) ASSERT_TRUE(sim.simulator->step().ok);
  ASSERT_TRUE(sim.simulator->pinInPlace(40).ok());
  for (int k = 0; k < 10; ++k) ASSERT_TRUE(sim.simulator->step().ok);
  auto& integrator = dynamic_cast<ImplicitIntegrator&>(sim.simulator->integrator());
  ASSERT_NE(integrator.linearSolver(), nullptr);
  EXPECT_EQ(integrator.linearSolver()->analyses(), 1);
}

TEST(Factorisation, ProjectiveDynamicsFactorisesOncePerPinSet) {
  Simulation sim = simulation({"integrator.name=projective_dynamics", "material.model=arap",
                               "mesh.rows=9", "mesh.cols=9"});
  auto& pd = dynamic_cast<ProjectiveDynamics&>(sim.simulator->integrator());
  for (int k = 0; k < 20; ++k) ASSERT_TRUE(sim.simulator->step().ok);
  EXPECT_EQ(pd.factorisations(), 1);
  // Moving a pin's target keeps the factorisation; a new pinned vertex needs a new one.
  ASSERT_TRUE(sim.simulator->pin(0, Eigen::Vector3d(0.0, 0.0, 0.1)).ok());
  for (int k = 0; k < 5; ++k) ASSERT_TRUE(sim.simulator->step().ok);
  EXPECT_EQ(pd.factorisations(), 1);
  ASSERT_TRUE(sim.simulator->pinInPlace(40).ok());
  for (int k = 0; k < 5; ++k) ASSERT_TRUE(sim.simulator->step().ok);
  EXPECT_EQ(pd.factorisations(), 2);
}
