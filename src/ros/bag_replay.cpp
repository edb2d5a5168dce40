#include "fem_cloth/ros/bag_replay.h"

#include <std_msgs/String.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>

#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/ros/simulation_driver.h"

namespace fem_cloth {

namespace {

Expected<YAML::Node> sceneDocument(const RecordedRun* run, const BagRunOptions& options) {
  if (!options.sceneFile.empty()) return loadSceneDocument(options.sceneFile, options.overrides);
  if (run == nullptr || run->sceneYaml.empty()) {
    return Error{run == nullptr
                     ? "no scene: give --scene"
                     : "bag '" + run->path + "' holds no scene (" + RunTopics(options.node).scene +
                           "); record with launch/record.launch or give --scene"};
  }
  YAML::Node doc;
  try {
    doc = YAML::Load(run->sceneYaml);
  } catch (const YAML::Exception& e) {
    return Error{"the scene stored in bag '" + run->path + "' is not valid YAML: " + e.msg};
  }
  for (const std::string& o : options.overrides) {
    if (Status s = applySceneOverride(doc, o); !s) return Error{s.error()};
  }
  return doc;
}

class Progress {
 public:
  Progress(std::uint64_t total, bool enabled)
      : total_(total), enabled_(enabled && total > 0), tty_(isatty(STDERR_FILENO) != 0),
        start_(std::chrono::steady_clock::now()), last_(start_) {}
  void update(std::uint64_t done) {
    if (!enabled_) return;
    const auto now = std::chrono::steady_clock::now();
    if (std::chrono::duration<double>(now - last_).count() < (tty_ ? 0.5 : 5.0)) return;
    last_ = now;
    const double wall = std::chrono::duration<double>(now - start_).count();
    const double f = static_cast<double>(done) / static_cast<double>(total_);
    std::fprintf(stderr, "%sprogress: step %llu / %llu (%3.0f%%), ETA %.0f s%s", tty_ ? "\r" : "",
                 static_cast<unsigned long long>(done), static_cast<unsigned long long>(total_),
                 100 * f, f > 0 ? wall * (1 - f) / f : 0.0, tty_ ? "   " : "\n");
    dirty_ = tty_;
  }
  ~Progress() {
    if (dirty_) std::fprintf(stderr, "\n");
  }

 private:
  std::uint64_t total_;
  bool enabled_, tty_, dirty_ = false;
  std::chrono::steady_clock::time_point start_, last_;
};

}  // namespace

Expected<BagRunReport> runToBag(const std::string& inBag, const std::string& outBag,
                                const BagRunOptions& options) {
  const RunTopics topics(options.node);
  std::optional<RecordedRun> run;
  if (!inBag.empty()) {
    Expected<RecordedRun> read = readRun(inBag, options.node);
    if (!read) return Error{read.error()};
    run = std::move(read).value();
  }
  Expected<YAML::Node> doc = sceneDocument(run ? &*run : nullptr, options);
  if (!doc) return Error{doc.error()};
  Expected<Scene> scene = parseScene(*doc, options.sceneFile);
  if (!scene) return Error{"scene: " + scene.error()};
  Expected<Simulation> simulation = buildSimulation(*scene);
  if (!simulation) return Error{"scene: " + simulation.error()};
  if (run && run->mesh) {
    if (Status s = checkMeshMatches(*run->mesh, *simulation->mesh); !s) {
      return Error{"bag '" + inBag + "': " + s.error()};
    }
  }
  const double dt = scene->dt;
  DriverSettings settings;
  settings.epoch = ros::Time(0);
  if (run) {
    settings.epoch = runEpoch(*run, dt).value_or(run->begin);
    if (!run->frame.empty()) settings.frame = run->frame;
  }
  BagRunReport report;
  report.scene = scene->name;
  report.warnings = simulation->warnings;
  SimulationDriver driver(std::move(simulation).value(), *scene, settings,
                          run ? run->tf.get() : nullptr);
  report.integrator = driver.simulator().integrator().name();

  // Every command up front: the driver applies each at its stamp.
  std::map<std::uint64_t, std::string> recorded;  // step -> hash
  double lastCommand = 0.0;
  if (run) {
    report.exactCommands = run->exactCommands;
    for (const PinCommand& c : run->pins) {
      ++report.pinCommands;
      lastCommand = std::max(lastCommand, (c.header.stamp - settings.epoch).toSec());
      if (Status s = driver.submit(c); !s) {
        ++report.rejected;
        report.warnings.push_back("pin command rejected (as live): " + s.error());
      }
    }
    for (const ForceCommand& c : run->forces) {
      ++report.forceCommands;
      lastCommand = std::max(lastCommand, (c.header.stamp - settings.epoch).toSec());
      if (Status s = driver.submit(c); !s) {
        ++report.rejected;
        report.warnings.push_back("force command rejected (as live): " + s.error());
      }
    }
    for (const RecordedState& s : run->states) recorded[s.step] = s.hash;
  }
  double duration = options.duration;
  if (!(duration > 0.0)) {
    if (!recorded.empty()) {
      duration = static_cast<double>(recorded.rbegin()->first) * dt;
    } else if (report.pinCommands + report.forceCommands > 0) {
      duration = lastCommand + 1.0;
    } else {
      duration = scene->duration;
    }
  }
  const std::uint64_t total = static_cast<std::uint64_t>(std::llround(std::ceil(duration / dt - 1e-9)));
  const std::uint64_t every =
      options.every > 0 ? static_cast<std::uint64_t>(options.every)
                        : std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::llround(1.0 / (30.0 * dt))));
  auto wanted = [&](std::uint64_t step) {
    if (options.every <= 0 && !recorded.empty()) return recorded.count(step) > 0;
    return step % every == 0 || step == total;
  };

  Expected<std::unique_ptr<RunWriter>> writer = RunWriter::open(outBag);
  if (!writer) return Error{writer.error()};
  RunWriter& out = **writer;
  std_msgs::String sceneMsg;
  sceneMsg.data = sceneDocumentToString(*doc);
  const ros::Time origin = driver.stampOf(0.0).isZero() ? ros::Time(1e-9) : driver.stampOf(0.0);
  out.write(topics.scene, origin, sceneMsg);
  out.write(topics.mesh, origin, driver.meshMessage());
  auto record = [&](const StepReport& r, double wall) {
    const ros::Time t = driver.now().isZero() ? origin : driver.now();
    const ClothState state = driver.stateMessage();
    out.write(topics.state, t, state);
    out.write(topics.energy, t, driver.energyMessage());
    out.write(topics.stats, t, driver.statsMessage(r, wall, 0.0));
    auto it = recorded.find(state.step);
    if (it != recorded.end()) {
      ++report.compared;
      if (it->second == state.state_hash) {
        ++report.identical;
      } else if (report.compared == report.identical + 1) {
        report.firstMismatch = state.step;
      }
    }
  };
  if (wanted(0)) record(StepReport(), 0.0);

  Progress progress(total, options.progress);
  const auto start = std::chrono::steady_clock::now();
  for (std::uint64_t k = 0; k < total; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    std::string missing;
    if (!driver.transformsReady(&missing)) {
      report.warnings.push_back("step " + std::to_string(k + 1) + ": the bag has no transform for " +
                                missing + "; the newest one is used (as the node did if it did)");
    }
    const StepReport r = driver.step();
    for (std::string& w : driver.takeWarnings()) report.warnings.push_back(std::move(w));
    for (PinCommand& c : driver.takeAppliedPins()) out.write(topics.appliedPin, c.header.stamp, c);
    for (ForceCommand& c : driver.takeAppliedForces()) out.write(topics.appliedForce, c.header.stamp, c);
    if (!r.ok) {
      return Error{"the simulation failed at step " + std::to_string(k + 1) + ": " + r.error};
    }
    ++report.steps;
    if (wanted(driver.stepIndex())) {
      record(r, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    progress.update(k + 1);
  }
  report.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  report.simulated = driver.simulator().time();
  report.finalHash = stateHash(driver.simulator().state().x, driver.simulator().state().v);
  report.energy = driver.simulator().energies();
  report.stretch = EdgeStretchMeter(driver.simulator().model().mesh()).measure(driver.simulator().state().x);
  if (Status s = out.close(); !s) return Error{s.error()};
  return report;
}

}  // namespace fem_cloth
