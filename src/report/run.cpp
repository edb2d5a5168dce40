#include "fem_cloth/report/run.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "fem_cloth/core/membrane.h"
#include "fem_cloth/core/metrics.h"
#include "fem_cloth/io/scene_yaml.h"

namespace fem_cloth::report {

namespace {

// Bump when what a reference run computes changes (the core's numerics are covered by the
// scene text only as far as the scene says; a changed integrator needs a new version or an
// emptied cache: scripts/report --fresh).
constexpr const char* kCacheFormat = "fem_cloth_reference 1";

std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// How many steps of dt make `interval`, if a whole number does (to 1e-9 relative).
std::optional<std::uint64_t> stepsIn(double interval, double dt) {
  const double ratio = interval / dt;
  const double whole = std::round(ratio);
  if (whole < 1.0 || std::abs(ratio - whole) > 1e-9 * std::max(1.0, ratio)) return std::nullopt;
  return static_cast<std::uint64_t>(whole);
}

}  // namespace

bool wholeSteps(double interval, double dt) { return stepsIn(interval, dt).has_value(); }

Expected<double> cflBound(const YAML::Node& document) {
  Expected<Scene> scene = parseScene(document);
  if (!scene) return Error{"scene: " + scene.error()};
  Expected<Simulation> built = buildSimulation(*scene);
  if (!built) return Error{built.error()};
  Simulator& sim = *built->simulator;
  std::vector<char> pinned(static_cast<std::size_t>(sim.model().numDofs()), 0);
  for (Index v : sim.pinnedVertices()) {
    for (int k = 0; k < sim.dim(); ++k) pinned[static_cast<std::size_t>(sim.dim() * v + k)] = 1;
  }
  // stableStep keeps its power-iteration buffers in the stepper: a throwaway one serves here.
  SymplecticEuler probe;
  return probe.stableStep(sim.model(), sim.state().x, pinned, scene->damping);
}

std::string outcomeName(RunResult::Outcome outcome) {
  switch (outcome) {
    case RunResult::Outcome::Completed: return "completed";
    case RunResult::Outcome::Failed: return "failed";
    case RunResult::Outcome::BuildError: return "build_error";
    case RunResult::Outcome::NonFinite: return "non_finite";
    case RunResult::Outcome::OverBudget: return "over_budget";
  }
  return "unknown";
}

std::string hashText(const std::string& text) {
  std::uint64_t h = 1469598103934665603ULL;
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ULL;
  }
  std::ostringstream s;
  s << std::hex << std::setw(16) << std::setfill('0') << h;
  return s.str();
}

RunResult runScene(const RunRequest& request) {
  RunResult out;
  Expected<Scene> scene = parseScene(request.scene);
  if (!scene) {
    out.outcome = RunResult::Outcome::BuildError;
    out.error = "scene: " + scene.error();
    return out;
  }
  Expected<Simulation> built = buildSimulation(*scene);
  if (!built) {
    out.outcome = RunResult::Outcome::BuildError;
    out.error = built.error();
    return out;
  }
  const double dt = scene->dt;
  const double duration = request.duration > 0.0 ? request.duration : scene->duration;
  const std::optional<std::uint64_t> total = stepsIn(duration, dt);
  const std::optional<std::uint64_t> every =
      request.sampleInterval > 0.0 ? stepsIn(request.sampleInterval, dt) : total;
  if (!total || !every) {
    out.outcome = RunResult::Outcome::BuildError;
    out.error = "dt = " + numberText(dt) + " s does not divide the duration " + numberText(duration) +
                " s and the sample interval " + numberText(request.sampleInterval) + " s";
    return out;
  }
  const std::shared_ptr<const Mesh> mesh = built->mesh;
  const EdgeStretchMeter stretchMeter(*mesh);

  // The stepping: the scene's own script, or the node's driver fed with a recorded run.
  std::unique_ptr<DrivenSimulation> driver;
  std::optional<Simulation> plain;
  if (request.commands) {
    driver = request.commands->drive(std::move(built).value(), request.scene,
                                     request.recordedDt > 0.0 ? request.recordedDt : dt);
  } else {
    plain.emplace(std::move(built).value());
  }
  // Looked up at each use: a live change among the recorded commands replaces the simulator.
  auto simulator = [&]() -> Simulator& { return driver ? driver->simulator() : *plain->simulator; };
  out.integrator = simulator().integrator().name();
  out.dim = simulator().dim();
  out.clothSize = restBoundingBoxDiagonal(*mesh);
  out.weightScale = simulator().model().totalMass() * accelerationScale(scene->gravity.norm()) * out.clothSize;

  double heldEnergy = 0.0, work = 0.0, maxBalance = -std::numeric_limits<double>::infinity();
  // Measures the state after a step (or the initial one); false if anything is non-finite.
  auto observe = [&](std::uint64_t k, bool sample) {
    const State& s = simulator().state();
    if (!s.x.allFinite() || !s.v.allFinite()) {
      out.outcome = RunResult::Outcome::NonFinite;
      out.error = "non-finite state after step " + std::to_string(k);
      return false;
    }
    const EnergyReport e = simulator().energies();
    if (!std::isfinite(e.total) || !std::isfinite(e.balanceError)) {
      out.outcome = RunResult::Outcome::NonFinite;
      out.error = "non-finite energy after step " + std::to_string(k) + " (total " + numberText(e.total) +
                  " J, balance error " + numberText(e.balanceError) + " J)";
      return false;
    }
    heldEnergy = std::max(heldEnergy, e.kinetic + e.strain + e.bending + std::abs(e.gravity));
    work = std::max(work, std::abs(e.externalWork) + std::abs(e.pinWork));
    maxBalance = std::max(maxBalance, e.balanceError);
    out.balanceMaxAbs = std::max(out.balanceMaxAbs, std::abs(e.balanceError));
    out.balanceEnd = e.balanceError;
    out.maxStretch = std::max(out.maxStretch, stretchMeter.measure(s.x).max);
    out.minJEnd = minAreaRatio(*mesh, simulator().model().rest(), s.x);
    out.minJ = std::min(out.minJ, out.minJEnd);
    if (sample && (k % *every == 0 || k == *total)) {
      out.samples.push_back(s.x);
      out.sampleTimes.push_back(s.time);
      out.sampleBalance.push_back(e.balanceError);
    }
    return true;
  };

  bool finite = observe(0, true);
  for (std::uint64_t k = 1; finite && k <= *total; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    StepReport r;
    if (driver) {
      r = driver->step();
    } else if (Status s = plain->script.applyDue(simulator()); !s) {
      r.ok = false;
      r.error = s.error();
    } else {
      r = simulator().step();
    }
    out.wall += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    out.rollbacks += static_cast<std::uint64_t>(r.rollbacks);
    if (!r.ok) {
      out.outcome = RunResult::Outcome::Failed;
      out.error = r.error;
      // The simulator keeps its last good state: it must be finite too.
      finite = observe(k - 1, false);
      break;
    }
    ++out.steps;
    out.substeps += static_cast<std::uint64_t>(r.substeps);
    out.maxSubsteps = std::max(out.maxSubsteps, static_cast<std::uint64_t>(r.substeps));
    out.newtonIterations += static_cast<std::uint64_t>(r.newtonIterations);
    finite = observe(k, true);
    if (finite && out.wall > request.wallBudget && k < *total) {
      out.outcome = RunResult::Outcome::OverBudget;
      out.error = "stopped after " + numberText(out.wall) + " s of wall time at t = " + numberText(simulator().time()) +
                  " s (budget " + numberText(request.wallBudget) + " s)";
      break;
    }
  }
  out.simulated = simulator().time();
  out.finalHash = stateHash(simulator().state().x, simulator().state().v);
  const double scale = std::max({out.weightScale, heldEnergy, work, 1e-12});
  out.energyGrowth = std::isfinite(maxBalance) ? maxBalance / scale : 0.0;
  return out;
}

PositionErrors positionErrors(const std::vector<VectorX>& run, const std::vector<VectorX>& reference,
                              int dim, double clothSize) {
  PositionErrors e;
  const std::size_t n = std::min(run.size(), reference.size());
  for (std::size_t k = 0; k < n; ++k) {
    const VectorX& a = run[k];
    const VectorX& b = reference[k];
    const Index vertices = a.size() / dim;
    double sum = 0.0, worst = 0.0;
    for (Index i = 0; i < vertices; ++i) {
      const double d2 = (a.segment(dim * i, dim) - b.segment(dim * i, dim)).squaredNorm();
      sum += d2;
      worst = std::max(worst, d2);
    }
    e.rms.push_back(std::sqrt(sum / static_cast<double>(std::max<Index>(vertices, 1))) / clothSize);
    e.max.push_back(std::sqrt(worst) / clothSize);
  }
  if (n > 0) {
    e.rmsEnd = e.rms.back();
    e.maxEnd = e.max.back();
    e.rmsOverTime = *std::max_element(e.rms.begin(), e.rms.end());
    e.maxOverTime = *std::max_element(e.max.begin(), e.max.end());
  }
  return e;
}

double fittedOrder(const std::vector<double>& dts, const std::vector<double>& errors) {
  double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0;
  int n = 0;
  for (std::size_t i = 0; i < std::min(dts.size(), errors.size()); ++i) {
    if (!(dts[i] > 0.0) || !(errors[i] > 0.0) || !std::isfinite(errors[i])) continue;
    const double x = std::log(dts[i]), y = std::log(errors[i]);
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
    ++n;
  }
  if (n < 2) return std::nan("");
  const double denominator = n * sxx - sx * sx;
  if (!(std::abs(denominator) > 0.0)) return std::nan("");
  return (n * sxy - sx * sy) / denominator;
}

namespace {

template <class T>
void put(std::ostream& out, const T& value) {
  out.write(reinterpret_cast<const char*>(&value), sizeof(T));
}
template <class T>
bool get(std::istream& in, T& value) {
  return static_cast<bool>(in.read(reinterpret_cast<char*>(&value), sizeof(T)));
}

Status writeReference(const std::string& path, const RunResult& r) {
  const std::string partial = path + ".partial";
  {
    std::ofstream out(partial, std::ios::binary);
    if (!out) return Error{"cannot write '" + partial + "'"};
    out << kCacheFormat << '\n';
    put(out, static_cast<std::uint64_t>(r.samples.size()));
    put(out, static_cast<std::uint64_t>(r.samples.empty() ? 0 : r.samples.front().size()));
    put(out, static_cast<std::int32_t>(r.dim));
    for (double v : {r.clothSize, r.weightScale, r.wall, r.simulated, r.balanceEnd, r.balanceMaxAbs,
                     r.energyGrowth, r.maxStretch, r.minJ}) {
      put(out, v);
    }
    for (std::uint64_t v : {r.steps, r.substeps, r.maxSubsteps, r.rollbacks, r.newtonIterations}) put(out, v);
    for (std::size_t k = 0; k < r.samples.size(); ++k) {
      put(out, r.sampleTimes[k]);
      put(out, r.sampleBalance[k]);
      out.write(reinterpret_cast<const char*>(r.samples[k].data()),
                static_cast<std::streamsize>(sizeof(double) * r.samples[k].size()));
    }
    if (!out) return Error{"cannot write '" + partial + "'"};
  }
  std::error_code ec;
  std::filesystem::rename(partial, path, ec);
  if (ec) return Error{"cannot rename '" + partial + "': " + ec.message()};
  return Status::success();
}

std::optional<RunResult> readReference(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::string magic;
  if (!std::getline(in, magic) || magic != kCacheFormat) return std::nullopt;
  RunResult r;
  std::uint64_t count = 0, dofs = 0;
  std::int32_t dim = 0;
  if (!get(in, count) || !get(in, dofs) || !get(in, dim)) return std::nullopt;
  r.dim = dim;
  for (double* v : {&r.clothSize, &r.weightScale, &r.wall, &r.simulated, &r.balanceEnd,
                    &r.balanceMaxAbs, &r.energyGrowth, &r.maxStretch, &r.minJ}) {
    if (!get(in, *v)) return std::nullopt;
  }
  for (std::uint64_t* v : {&r.steps, &r.substeps, &r.maxSubsteps, &r.rollbacks, &r.newtonIterations}) {
    if (!get(in, *v)) return std::nullopt;
  }
  for (std::uint64_t k = 0; k < count; ++k) {
    double t = 0.0, balance = 0.0;
    if (!get(in, t) || !get(in, balance)) return std::nullopt;
    VectorX x(static_cast<Index>(dofs));
    if (!in.read(reinterpret_cast<char*>(x.data()), static_cast<std::streamsize>(sizeof(double) * dofs))) {
      return std::nullopt;
    }
    r.sampleTimes.push_back(t);
    r.sampleBalance.push_back(balance);
    r.samples.push_back(std::move(x));
  }
  return r;
}

}  // namespace

Expected<Reference> cachedReference(const RunRequest& request, const std::string& commandsBag,
                                    const std::string& cacheDir) {
  std::ostringstream keyText;
  keyText << std::setprecision(17) << kCacheFormat << '\n'
          << sceneDocumentToString(request.scene) << "\nduration=" << request.duration
          << "\nsample_interval=" << request.sampleInterval << "\nrecorded_dt=" << request.recordedDt
          << "\ncommands=" << (commandsBag.empty() ? std::string("none") : hashText(readBytes(commandsBag)))
          << '\n';
  Reference ref;
  ref.key = hashText(keyText.str());
  const std::string path = cacheDir.empty() ? "" : cacheDir + "/reference-" + ref.key + ".bin";
  if (!path.empty()) {
    if (std::optional<RunResult> r = readReference(path)) {
      ref.run = std::move(*r);
      ref.run.integrator = "bdf2";
      ref.cached = true;
      return ref;
    }
  }
  ref.run = runScene(request);
  if (ref.run.outcome != RunResult::Outcome::Completed) {
    return Error{"the reference run failed (" + outcomeName(ref.run.outcome) + "): " + ref.run.error};
  }
  if (!path.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(cacheDir, ec);
    if (Status s = writeReference(path, ref.run); !s) return Error{s.error()};
  }
  return ref;
}

}  // namespace fem_cloth::report
