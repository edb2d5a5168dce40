// fem_cloth's benchmarks (Google Benchmark). scripts/bench runs them and prints the tables of
// docs/performance.md; run this program directly for the raw figures:
//   fem_cloth_bench [--benchmark_filter=Step] [--benchmark_format=json]
//
// Families:
//   Kernel/<model>          psi and P of one cloth (3 x 2) element
//   KernelHessian/<model>   its PSD-projected stress Hessian
//   Assembly/<n>            membrane gradient and projected Hessian of an n x n grid
//   Step/<integrator>/<n>   one step of the hanging cloth (n x n) in steady state
//   StepBending/<model>/<n> the same with bending (backward Euler), per bending model
//   HangingCloth65          the 2 s run of config/hanging_cloth_fast.yaml
#include <benchmark/benchmark.h>

#include <random>

#include "fem_cloth/core/bending.h"
#include "fem_cloth/core/membrane.h"
#include "fem_cloth/core/metrics.h"
#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/core/threads.h"

using namespace fem_cloth;

namespace {

const std::string kSource = FEM_CLOTH_SOURCE_DIR;

DefGrad<3> sampleF(unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 0.1);
  DefGrad<3> F;
  F << 1.0 + n(rng), n(rng), n(rng), 1.0 + n(rng), n(rng), n(rng);
  return F;
}

template <class M>
void kernel(benchmark::State& state, bool hessian) {
  const M model(Lame{1.0, 1.0});
  DefGrad<3> T = DefGrad<3>::Zero();
  T(0, 0) = T(1, 1) = 1.0;
  std::vector<DefGrad<3>> samples;
  for (unsigned k = 0; k < 64; ++k) samples.push_back(sampleF(k));
  std::size_t k = 0;
  for (auto _ : state) {
    const DefGrad<3>& F = samples[k++ & 63];
    if (hessian) {
      benchmark::DoNotOptimize(model.template projectedHessian<3>(F, T));
    } else {
      benchmark::DoNotOptimize(model.template psi<3>(F, T));
      benchmark::DoNotOptimize(model.template pk1<3>(F, T));
    }
  }
  state.SetItemsProcessed(state.iterations());
}

template <class M>
void registerKernels() {
  benchmark::RegisterBenchmark((std::string("Kernel/") + M::kName).c_str(),
                               [](benchmark::State& s) { kernel<M>(s, false); });
  benchmark::RegisterBenchmark((std::string("KernelHessian/") + M::kName).c_str(),
                               [](benchmark::State& s) { kernel<M>(s, true); });
}

Simulation hangingCloth(int n, const std::vector<std::string>& more) {
  std::vector<std::string> overrides = {"mesh.rows=" + std::to_string(n),
                                        "mesh.cols=" + std::to_string(n)};
  overrides.insert(overrides.end(), more.begin(), more.end());
  Expected<Scene> scene = loadScene(kSource + "/config/hanging_cloth.yaml", overrides);
  if (!scene) throw std::runtime_error(scene.error());
  Expected<Simulation> sim = buildSimulation(*scene);
  if (!sim) throw std::runtime_error(sim.error());
  return std::move(sim).value();
}

void assembly(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  Simulation sim = hangingCloth(n, {});
  Model& model = *sim.model;
  SparseHessian& H = model.hessianPattern();
  VectorX x = sim.mesh->restPositions, g(x.size());
  for (Eigen::Index i = 0; i < x.size(); ++i) x[i] += 1e-3 * std::sin(0.3 * static_cast<double>(i));
  EvalRequest request;
  request.gradient = &g;
  request.hessian = &H;
  for (auto _ : state) {
    g.setZero();
    H.setZero();
    benchmark::DoNotOptimize(model.evaluate(x, request).energy);
  }
  state.counters["triangles"] = sim.mesh->numTriangles();
  state.counters["us_per_triangle"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * sim.mesh->numTriangles(),
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// One step of the hanging cloth in steady state (after a warm-up that absorbs set-up work).
void step(benchmark::State& state, const std::vector<std::string>& settings) {
  const int n = static_cast<int>(state.range(0));
  Simulation sim = hangingCloth(n, settings);
  Simulator& s = *sim.simulator;
  for (int k = 0; k < 3; ++k) s.step();
  long substeps = 0;
  for (auto _ : state) {
    const StepReport r = s.step();
    if (!r.ok) {
      state.SkipWithError(r.error.c_str());
      break;
    }
    substeps += r.substeps;
  }
  const EdgeStretch st = EdgeStretchMeter(*sim.mesh).measure(s.state().x);
  state.counters["vertices"] = sim.mesh->numVertices();
  state.counters["dt"] = s.settings().dt;
  state.counters["substeps"] = static_cast<double>(substeps) / std::max<double>(1, state.iterations());
  state.counters["mean_stretch"] = st.mean;
  state.counters["max_stretch"] = st.max;
}

void hangingCloth65(benchmark::State& state) {
  for (auto _ : state) {
    state.PauseTiming();
    Expected<Scene> scene = loadScene(kSource + "/config/hanging_cloth_fast.yaml");
    Expected<Simulation> sim = buildSimulation(*scene);
    state.ResumeTiming();
    for (int k = 0; k < 120; ++k) sim->simulator->step();
    state.PauseTiming();
    const EdgeStretch st = EdgeStretchMeter(*sim->mesh).measure(sim->simulator->state().x);
    state.counters["mean_stretch"] = st.mean;
    state.counters["max_stretch"] = st.max;
    state.counters["simulated_s"] = sim->simulator->time();
    state.ResumeTiming();
  }
}

struct StepConfig {
  std::string name;
  std::vector<std::string> settings;
  int largest;  // largest grid it is run on (the slow ones stop earlier)
};

}  // namespace

int main(int argc, char** argv) {
  fem_cloth::preferPassiveThreadWaiting(argv);
  registerKernels<LinearElasticity>();
  registerKernels<StVenantKirchhoff>();
  registerKernels<Corotational>();
  registerKernels<Arap>();
  registerKernels<NeoHookean>();
  registerKernels<StableNeoHookean>();
  benchmark::RegisterBenchmark("Assembly", assembly)
      ->Arg(17)->Arg(33)->Arg(65)->Arg(129)->Unit(benchmark::kMillisecond);
  const std::vector<StepConfig> configs = {
      {"projective_dynamics",
       {"integrator.name=projective_dynamics", "material.model=arap",
        "integrator.dt=0.016666666666666666", "integrator.iterations=7",
        "integrator.chebyshev_rho=0.9"},
       129},
      {"symplectic_euler", {"integrator.name=symplectic_euler"}, 129},
      {"xpbd", {"integrator.name=xpbd", "integrator.substeps=10", "integrator.iterations=1"}, 129},
      {"backward_euler", {"integrator.name=backward_euler"}, 65},
      {"bdf2", {"integrator.name=bdf2"}, 33},
  };
  for (const StepConfig& c : configs) {
    auto* b = benchmark::RegisterBenchmark(("Step/" + c.name).c_str(),
                                           [c](benchmark::State& s) { step(s, c.settings); });
    for (int n : {17, 33, 65, 129}) {
      if (n <= c.largest) b->Arg(n);
    }
    b->Unit(benchmark::kMillisecond)->MinTime(0.3);
  }
  // The hanging cloth with bending (1e-5 N m, as in the contact scenes) under each bending model,
  // backward Euler: what a bending model costs per step (docs/bending.md).
  for (const std::string& model : bendingModelNames()) {
    auto* b = benchmark::RegisterBenchmark(("StepBending/" + model).c_str(), [model](benchmark::State& s) {
      step(s, {"integrator.name=backward_euler", "bending.stiffness=1e-5", "bending.model=" + model});
    });
    b->Arg(17)->Arg(33)->Unit(benchmark::kMillisecond)->MinTime(0.3);
  }
  benchmark::RegisterBenchmark("HangingCloth65", hangingCloth65)
      ->Unit(benchmark::kMillisecond)
      ->Iterations(3);
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
