#include "fem_cloth/ros/bag_replay.h"

#include <std_msgs/String.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>

#include "fem_cloth/core/integrators/implicit.h"
#include "fem_cloth/io/output_file.h"
#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/ros/simulation_driver.h"
#include "fem_cloth/ros/time_checks.h"
#include "fem_cloth/ros/time_text.h"

namespace fem_cloth {

namespace {

Expected<YAML::Node> sceneDocument(const RecordedRun* run, const BagRunOptions& options) {
  if (!options.sceneFile.empty()) return loadSceneDocument(options.sceneFile, options.overrides);
  if (run == nullptr) return Error{"no scene: give --scene"};
  Expected<YAML::Node> doc = storedScene(*run, options.node);
  if (!doc) return Error{doc.error() + " (--scene)"};
  FEM_CLOTH_CHECK(applySceneOverrides(*doc, options.overrides));
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

// The step of the recorded run, which dates its states: that of the scene stored in the bag
// (a replay with --scene or --set may step differently), else the replay's.
double recordedDt(const RecordedRun& run, double replayDt) {
  if (run.sceneYaml.empty()) return replayDt;
  try {
    const Expected<Scene> recorded = parseScene(YAML::Load(run.sceneYaml));
    if (recorded) return recorded->dt;
  } catch (const YAML::Exception&) {
  }
  return replayDt;
}

// The timeline of the replay: the recorded states' (runTimeline()), else from the start of the
// bag (or 0 without one). Every stamp the replay compares with it lies within kMaxRecordingSpan
// of the start of the recording (readRun), so keeping its origin there too keeps their
// differences within what ros::Duration holds.
Expected<Timeline> timelineOf(const RecordedRun* run, double dt) {
  if (run == nullptr) return Timeline(ros::Time(0));
  if (run->states.empty()) return Timeline(run->begin);
  const std::optional<Timeline> timeline = runTimeline(*run, recordedDt(*run, dt));
  const RecordedState& first = run->states.front();
  if (!timeline || std::abs(secondsBetween(timeline->origin(), run->begin)) > kMaxRecordingSpan) {
    return Error{"bag '" + run->path + "': its first state (step " + std::to_string(first.step) +
                 ", stamp " + rosTimeText(first.stamp) + " s) does not fit a run that "
                 "started within the recording at the step " + numberText(recordedDt(*run, dt)) + " s"};
  }
  return *timeline;
}

// What a replay takes from its recording.
struct ReplaySettings {
  std::map<std::uint64_t, std::string> recorded;  ///< step -> state hash
  double lastRecorded = 0.0;  ///< s: the last recorded state's step x dt (0: none)
  double lastCommand = 0.0;   ///< s from the time origin to the last command's stamp
  bool anyCommand = false;
  ros::Time origin;     ///< the timeline's: ROS time of simulation time 0
  ros::Time reference;  ///< the start of the recording (0 without one)
};

// What the replay of `run` takes from it, counting its commands per topic in `report` (the
// CommandFeed submits them).
ReplaySettings replaySettings(const RecordedRun* run, const Timeline& timeline, double dt, BagRunReport& report) {
  ReplaySettings settings;
  settings.origin = timeline.origin();
  if (run == nullptr) return settings;
  settings.reference = run->begin;
  report.exactCommands = run->exactCommands;
  settings.anyCommand = !run->commands.empty();
  for (const Command& c : run->commands) {
    ++report.commands[static_cast<std::size_t>(topicOf(c))];
    settings.lastCommand = std::max(settings.lastCommand, secondsBetween(headerOf(c).stamp, settings.origin));
  }
  for (const RecordedState& s : run->states) settings.recorded[s.step] = s.hash;
  if (!settings.recorded.empty()) settings.lastRecorded = static_cast<double>(settings.recorded.rbegin()->first) * dt;
  return settings;
}

// The recorded commands, each submitted to the driver just before the step it takes effect
// before, as the node had received it by then: the driver judges it against the scene as it is
// at that moment (a move or removal of an obstacle added live needs the obstacle), not as it was
// when the replay started. Those due before the same step are submitted in the recording's order,
// so they take effect in the same order as when all were queued up front.
class CommandFeed {
 public:
  explicit CommandFeed(std::vector<Command> commands) : commands_(std::move(commands)) {}

  /// Submits the commands due before the driver's next step; `rejected` is told of each the
  /// driver refuses (as the node did: the recording holds what it applied). The driver keeps its
  /// timeline from the first call on.
  void submitDue(SimulationDriver& driver, const std::function<void(const Command&, const Status&)>& rejected) {
    const double t = driver.simulator().time();
    const double dt = driver.simulator().settings().dt;
    if (submitted_.size() != commands_.size()) {
      for (std::size_t k = 0; k < commands_.size(); ++k) order_.emplace_back(timeOf(driver, commands_[k], dt), k);
      std::stable_sort(order_.begin(), order_.end(), [](const Entry& a, const Entry& b) { return a.first < b.first; });
      submitted_.assign(commands_.size(), false);
    }
    std::vector<std::size_t> due;
    // Times placed ahead of the segment they fall in (Timeline::timeOf before reach()) are off by
    // round-off only: half a step holds every command that can be due now.
    for (std::size_t k = next_; k < order_.size() && order_[k].first <= t + 0.5 * dt; ++k) {
      const std::size_t index = order_[k].second;
      // The driver's own rule (SimulationDriver::applyDue): due at or before t, to 1e-9 dt.
      if (!submitted_[index] && timeOf(driver, commands_[index], dt) <= t + 1e-9 * dt) due.push_back(index);
    }
    std::sort(due.begin(), due.end());
    for (std::size_t index : due) {
      submitted_[index] = true;
      if (Status s = driver.submit(commands_[index]); !s) rejected(commands_[index], s);
    }
    while (next_ < order_.size() && submitted_[order_[next_].second]) ++next_;
  }

 private:
  using Entry = std::pair<double, std::size_t>;  // (simulation time, index in commands_)
  // The simulation time a command stands for; -inf for a zero stamp (the next step) and for a
  // stamp the timeline cannot place: the driver refuses that one, naming it, when submitted.
  static double timeOf(const SimulationDriver& driver, const Command& c, double dt) {
    const ros::Time& stamp = headerOf(c).stamp;
    if (stamp.isZero()) return -std::numeric_limits<double>::infinity();
    const Expected<double> t = driver.timeline().timeOf(stamp, dt, "header.stamp");
    return t ? *t : -std::numeric_limits<double>::infinity();
  }

  std::vector<Command> commands_;
  std::vector<Entry> order_;
  std::vector<bool> submitted_;
  std::size_t next_ = 0;
};

// How long the run lasts (s): --duration, else up to the last recorded state, the last command
// + 1 s, or the scene's duration; within kMaxSteps steps and, stamped from the origin, within
// the recording's span and ros::Time.
Expected<double> replayDuration(double wanted, const Scene& scene, const ReplaySettings& replay) {
  double duration = wanted;
  std::string what = "--duration";
  if (!(duration > 0.0)) {
    if (replay.lastRecorded > 0.0) {
      duration = replay.lastRecorded;
      what = "the last recorded state";
    } else if (replay.anyCommand) {
      duration = replay.lastCommand + 1.0;
      what = "the last command";
    } else {
      duration = scene.duration;
      what = "the scene's duration";
    }
  }
  FEM_CLOTH_CHECK(checkStepCount(duration, scene.dt, scene.substeps, what));
  const double end = replay.origin.toSec() + duration;
  if (!(secondsBetween(replay.origin, replay.reference) + duration <= kMaxRecordingSpan && end < 4294967295.0)) {
    return Error{what + ": the run would end at ROS time " + secondsText(end) + " s, beyond " +
                 (end < 4294967295.0 ? "the span a recording can have (1e+09 s)" : "the largest ROS time")};
  }
  return duration;
}

// The commands the step applied, topic after topic, each on its applied_ topic.
void writeApplied(SimulationDriver& driver, const RunTopics& topics, RunWriter& out) {
  forEachCommandType([&](auto type) {
    using C = typename decltype(type)::type;
    for (const C& c : driver.takeApplied<C>()) out.write(topics.applied(topicOf<C>()), c.header.stamp, c);
  });
}

// Refuses a bag with a recorded state that cannot be a state of a cloth of `vertices` vertices,
// naming it, before any work.
Status checkRecordedStates(const std::string& path, const std::string& node, std::size_t vertices) {
  Expected<std::unique_ptr<StateReader>> reader = StateReader::open(path, node);
  if (!reader) return Error{reader.error()};
  ClothState state;
  for (;;) {
    const Expected<bool> got = (*reader)->next(state);
    if (!got) return Error{got.error()};
    if (!*got) return Status::success();
    if (const std::string why = stateDamage(state, vertices); !why.empty()) {
      return Error{"bag '" + path + "': " + (*reader)->name(state) + " is damaged: " + why};
    }
  }
}

// Copies every /tf and /tf_static message of the recording `inBag` into `out`, as recorded: the
// replayed commands were taken in those frames (a pin in a gripper's frame), so a replay of `out`
// needs them as much as this replay needed them (issue 31).
Status copyTransforms(const std::string& inBag, RunWriter& out) {
  if (!out.writes()) return Status::success();
  try {
    rosbag::Bag bag(inBag, rosbag::bagmode::Read);
    const std::vector<std::string> topics = {"/tf", "/tf_static"};
    for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery(topics))) out.copy(m);
  } catch (const std::exception& e) {
    // readRun read the same messages a moment ago: a bag changed since, or a full disk.
    return Error{"cannot copy the transforms of bag '" + inBag + "' into the output: " + e.what()};
  }
  return Status::success();
}

bool sameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// How far apart two lists of points or vectors are: the largest distance (and its vertex), and
// whether every coordinate has the same bits.
struct VertexDifference {
  bool sameBits = true;
  double largest = 0.0;
  std::size_t vertex = 0;
};

template <class V>
VertexDifference vertexDifference(const std::vector<V>& recorded, const std::vector<V>& simulated) {
  VertexDifference d;
  for (std::size_t i = 0; i < recorded.size() && i < simulated.size(); ++i) {
    const V& a = recorded[i];
    const V& b = simulated[i];
    d.sameBits = d.sameBits && sameBits(a.x, b.x) && sameBits(a.y, b.y) && sameBits(a.z, b.z);
    const double distance = std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z));
    if (distance > d.largest) {
      d.largest = distance;
      d.vertex = i;
    }
  }
  return d;
}

// The recorded states, compared in bag order with the re-simulation's as it reaches their steps.
class StateComparison {
 public:
  static Expected<StateComparison> open(const std::string& path, const std::string& node) {
    Expected<std::unique_ptr<StateReader>> reader = StateReader::open(path, node);
    if (!reader) return Error{reader.error()};
    StateComparison comparison(std::move(reader).value());
    FEM_CLOTH_CHECK(comparison.advance());
    return comparison;
  }
  std::size_t count() const { return reader_->count(); }

  /// Compares every recorded state of the driver's step with its state, counting in `report`.
  /// States of steps the replay went past without them are not compared.
  Status compare(const SimulationDriver& driver, BagRunReport& report) {
    const std::uint64_t step = driver.stepIndex();
    while (has_ && next_.step < step) FEM_CLOTH_CHECK(advance());
    if (!has_ || next_.step != step) return Status::success();
    const ClothState simulated = toMsg(driver.header(), driver.simulator().state(), driver.simulator().dim(), true);
    while (has_ && next_.step == step) {
      judge(simulated, report);
      FEM_CLOTH_CHECK(advance());
    }
    return Status::success();
  }

 private:
  explicit StateComparison(std::unique_ptr<StateReader> reader) : reader_(std::move(reader)) {}
  Status advance() {
    const Expected<bool> got = reader_->next(next_);
    if (!got) return Error{got.error()};
    has_ = *got;
    return Status::success();
  }

  void judge(const ClothState& simulated, BagRunReport& report) const {
    ++report.compared;
    const VertexDifference x = vertexDifference(next_.positions, simulated.positions);
    const bool withVelocities = !next_.velocities.empty();
    const VertexDifference v = withVelocities ? vertexDifference(next_.velocities, simulated.velocities) : VertexDifference();
    report.maxPositionDifference = std::max(report.maxPositionDifference, x.largest);
    report.maxVelocityDifference = std::max(report.maxVelocityDifference, v.largest);
    const bool sameHash = next_.state_hash == simulated.state_hash;
    if (x.sameBits && v.sameBits && sameHash) {
      ++report.identical;
      return;
    }
    if (!report.firstDifference.empty()) return;
    report.firstMismatch = next_.step;
    std::vector<std::string> parts;
    if (!x.sameBits) {
      parts.push_back("positions differ by up to " + numberText(x.largest) + " m (vertex " + std::to_string(x.vertex) + ")");
    }
    if (!v.sameBits) {
      parts.push_back("velocities differ by up to " + numberText(v.largest) + " m/s (vertex " + std::to_string(v.vertex) + ")");
    }
    if (parts.empty()) {
      parts.push_back(withVelocities ? "positions and velocities agree bit for bit, but the state hash differs (an altered hash)"
                                     : "positions agree bit for bit, but the state hash differs: the velocities, which "
                                       "the recording does not hold, differ (or the hash was altered)");
    }
    report.firstDifference = reader_->name(next_) + ": " + parts.front() + (parts.size() > 1 ? "; " + parts.back() : "");
  }

  std::unique_ptr<StateReader> reader_;
  ClothState next_;
  bool has_ = false;
};

}  // namespace

struct RunReplay::Impl {
  ReplaySettings settings;
  CommandFeed feed{std::vector<Command>()};
  std::optional<StateComparison> comparison;
  std::uint64_t steps = 0;
};

RunReplay::RunReplay() : impl_(std::make_unique<Impl>()) {}
RunReplay::~RunReplay() = default;

Expected<std::unique_ptr<RunReplay>> RunReplay::open(const RecordedRun* run, const std::string& node, const Scene& scene,
                                                     const Timeline& timeline, double duration, std::size_t vertices,
                                                     BagRunReport& report) {
  std::unique_ptr<RunReplay> replay(new RunReplay());
  Impl& r = *replay->impl_;
  if (run != nullptr) {
    FEM_CLOTH_CHECK(checkRecordedStates(run->path, node, vertices));
    Expected<StateComparison> opened = StateComparison::open(run->path, node);
    if (!opened) return Error{opened.error()};
    r.comparison.emplace(std::move(opened).value());
    report.recordedStates = r.comparison->count();
    r.feed = CommandFeed(run->commands);
  }
  r.settings = replaySettings(run, timeline, scene.dt, report);
  Expected<double> length = replayDuration(duration, scene, r.settings);
  if (!length) return Error{length.error()};
  r.steps = static_cast<std::uint64_t>(std::llround(std::ceil(*length / scene.dt - 1e-9)));
  return replay;
}

std::uint64_t RunReplay::steps() const { return impl_->steps; }

const std::map<std::uint64_t, std::string>& RunReplay::recordedStates() const { return impl_->settings.recorded; }

void RunReplay::submitDue(SimulationDriver& driver, const std::function<void(const Command&, const Status&)>& rejected) {
  impl_->feed.submitDue(driver, rejected);
}

Status RunReplay::compare(const SimulationDriver& driver, BagRunReport& report) {
  return impl_->comparison ? impl_->comparison->compare(driver, report) : Status::success();
}

Expected<Timeline> replayTimeline(const RecordedRun* run, double dt) { return timelineOf(run, dt); }

namespace {

// The SimulationDriver fed with a recorded run, as the report steps it.
class DriverRun : public DrivenSimulation {
 public:
  DriverRun(Simulation simulation, const YAML::Node& document, const RecordedRun& run, double recordedDt)
      : driver_(std::move(simulation), settingsFor(run, recordedDt), run.tf.get(), document), feed_(run.commands) {
    if (std::optional<Timeline> timeline = runTimeline(run, recordedDt)) driver_.setTimeline(*timeline);
  }
  Simulator& simulator() override { return driver_.simulator(); }
  StepReport step() override {
    // A command the driver rejects was rejected live as well (the recording holds the applied
    // stream): skipping it is what the node did.
    feed_.submitDue(driver_, [](const Command&, const Status&) {});
    return driver_.step();
  }

 private:
  static DriverSettings settingsFor(const RecordedRun& run, double dt) {
    DriverSettings settings;
    settings.epoch = runEpoch(run, dt).value_or(run.begin);
    if (!run.frame.empty()) settings.frame = run.frame;
    return settings;
  }
  SimulationDriver driver_;
  CommandFeed feed_;
};

class BagRecording : public Recording {
 public:
  BagRecording(RecordedRun run, std::string node) : run_(std::move(run)), node_(std::move(node)) {}
  const std::string& path() const override { return run_.path; }
  Expected<YAML::Node> scene() const override { return storedScene(run_, node_); }
  double recordedDuration() const override {
    double recorded = 0.0;
    for (const RecordedState& s : run_.states) recorded = std::max(recorded, secondsBetween(s.stamp, run_.states.front().stamp));
    return recorded;
  }
  std::unique_ptr<DrivenSimulation> drive(Simulation simulation, const YAML::Node& document,
                                          double recordedDt) const override {
    return std::make_unique<DriverRun>(std::move(simulation), document, run_, recordedDt);
  }

 private:
  RecordedRun run_;
  std::string node_;
};

}  // namespace

Expected<std::shared_ptr<const Recording>> readRecording(const std::string& path, const std::string& node) {
  Expected<RecordedRun> run = readRun(path, node);
  if (!run) return Error{run.error()};
  return std::shared_ptr<const Recording>(std::make_shared<BagRecording>(std::move(run).value(), node));
}

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
  FEM_CLOTH_CHECK(checkNotAnInput(outBag, {inBag, options.sceneFile, meshFilePath(*scene)}));
  // Found now rather than when the finished bag cannot be renamed into place.
  if (std::error_code ec; std::filesystem::is_directory(outBag, ec)) {
    return Error{"cannot write bag '" + outBag + "': it is a directory"};
  }
  Expected<Simulation> simulation = buildSimulation(*scene);
  if (!simulation) return Error{"scene: " + simulation.error()};
  if (run && run->mesh) {
    if (Status s = checkMeshMatches(*run->mesh, *simulation->mesh); !s) {
      return Error{"bag '" + inBag + "': " + s.error()};
    }
  }
  const double dt = scene->dt;
  DriverSettings settings;
  Expected<Timeline> timeline = timelineOf(run ? &*run : nullptr, dt);
  if (!timeline) return Error{timeline.error()};
  BagRunReport report;
  report.scene = scene->name;
  Expected<std::unique_ptr<RunReplay>> opened =
      RunReplay::open(run ? &*run : nullptr, options.node, *scene, *timeline, options.duration,
                      static_cast<std::size_t>(simulation->mesh->numVertices()), report);
  if (!opened) return Error{opened.error()};
  RunReplay& replay = **opened;
  settings.epoch = timeline->origin();
  if (run && !run->frame.empty()) settings.frame = run->frame;
  report.warnings = scene->warnings;
  report.warnings.insert(report.warnings.end(), simulation->warnings.begin(), simulation->warnings.end());
  if (run) report.warnings.insert(report.warnings.end(), run->warnings.begin(), run->warnings.end());
  SimulationDriver driver(std::move(simulation).value(), settings, run ? run->tf.get() : nullptr, *doc);
  driver.setTimeline(*timeline);
  report.integrator = driver.simulator().integrator().name();
  report.lbfgs = solvesByLbfgs(driver.simulator().integrator());

  auto submitDue = [&]() {
    replay.submitDue(driver, [&](const Command& c, const Status& s) {
      ++report.rejected;
      report.warnings.push_back(std::string(topicName(topicOf(c))) + " command rejected (as live): " + s.error());
    });
  };
  const std::map<std::uint64_t, std::string>& recorded = replay.recordedStates();
  const std::uint64_t total = replay.steps();
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
  out.write(topics.mesh, origin, toMsg(driver.simulator().model().mesh()));
  if (run) FEM_CLOTH_CHECK(copyTransforms(inBag, out));
  auto record = [&](const StepReport& r, double wall) {
    const ros::Time t = driver.now().isZero() ? origin : driver.now();
    const ClothState state = toMsg(driver.header(), driver.simulator().state(), driver.simulator().dim(), false);
    out.write(topics.state, t, state);
    out.write(topics.energy, t, toMsg(driver.header(), driver.stepIndex(), driver.simulator().energies()));
    out.write(topics.stats, t, statsMessage(driver, r, wall, 0.0));
  };
  // Every recorded state is compared when the replay reaches its step, written or not.
  auto compare = [&]() { return replay.compare(driver, report); };
  FEM_CLOTH_CHECK(compare());
  if (wanted(0)) record(StepReport(), 0.0);

  Progress progress(total, options.progress);
  const auto start = std::chrono::steady_clock::now();
  for (std::uint64_t k = 0; k < total; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    submitDue();
    std::string missing;
    if (!driver.transformsReady(&missing)) {
      report.warnings.push_back("step " + std::to_string(k + 1) + ": the bag has no transform for " +
                                missing + "; the newest one is used (as the node did if it did)");
    }
    const StepReport r = driver.step();
    for (std::string& w : driver.takeWarnings()) report.warnings.push_back(std::move(w));
    writeApplied(driver, topics, out);
    if (!r.ok) {
      report.stepTotals.addFailure(r);
      // No bag: the writer removes its temporary file.
      report.failure = "the simulation failed at step " + std::to_string(k + 1) + ": " + r.error;
      break;
    }
    ++report.steps;
    report.stepTotals.addStep(r);
    FEM_CLOTH_CHECK(compare());
    if (wanted(driver.stepIndex())) {
      record(r, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    progress.update(k + 1);
  }
  report.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  report.simulated = driver.simulator().time();
  report.finalHash = stateHash(driver.simulator().state().x, driver.simulator().state().v);
  report.energy = driver.simulator().energies();
  report.balance = driver.simulator().balance(report.energy);
  report.stretch = EdgeStretchMeter(driver.simulator().model().mesh()).measure(driver.simulator().state().x);
  if (report.failure.empty()) FEM_CLOTH_CHECK(out.close());
  return report;
}

}  // namespace fem_cloth
