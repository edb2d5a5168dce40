// fem_cloth_sim: runs a scene headless (no ROS master) and prints a summary.
//
//   fem_cloth_sim --scene config/hanging_cloth.yaml [--integrator NAME] [--dt S]
//                 [--duration S] [--set key=value]... [--out DIR | --out FILE.bag] [--every N]
//   fem_cloth_sim --commands recorded.bag [--out replay.bag] [--scene S] [--verify]
//   fem_cloth_sim --scene S [--set key=value]... --check [--write-scene FILE]
//
// --summary-json FILE also writes the summary for programs (fem_cloth_batch's index).
//
// Exit status: 0 success, 2 bad input (scene, bag, command line, an output that is an input),
// 3 the simulation failed (the error says why; CSV outputs hold everything up to the last good
// state, a bag is not written) or an unexpected internal error, 4 with --verify: a recorded state
// was not reproduced bit for bit (its positions, its velocities where recorded, its hash). A
// damaged recorded state (not finite, not one position per vertex) is bad input. Every error is
// one line on stderr. Outputs appear under their names only when complete (written to a
// temporary file next to them, then renamed).
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "fem_cloth/core/integrators/implicit.h"
#include "fem_cloth/core/integrators/step_totals.h"
#include "fem_cloth/core/membrane.h"
#include "fem_cloth/core/metrics.h"
#include "fem_cloth/core/threads.h"
#include "fem_cloth/io/command_line.h"
#include "fem_cloth/io/output_file.h"
#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/ros/bag_replay.h"
#include "fem_cloth/ros/simulation_driver.h"

using namespace fem_cloth;

namespace {

struct Options {
  std::string scene;
  std::string integrator;
  double dt = 0.0;
  double duration = 0.0;
  std::vector<std::string> overrides;
  std::string out;
  int every = 0;
  bool quiet = false;
  bool noOutput = false;
  std::string commands;
  std::string node = "/fem_cloth_node";
  bool verify = false;
  bool check = false;
  std::string writeScene;
  std::string summaryJson;
};

// Every message is one line on stderr, whatever names from the inputs (frames, topics) it quotes.
std::string oneLine(const std::string& text) { return printableText(text, 2000); }

// The steps' totals, and what the observer saw after each step.
struct Totals : StepTotals {
  double minAreaRatio = std::numeric_limits<double>::infinity();
  double maxStretch = -std::numeric_limits<double>::infinity();
};

/// The implicit steppers' error line: the worst displacement error of the accepted steps beside
/// the step's own truncation error there (acceptance test (a)); empty when none was measured.
std::string errorLine(const DisplacementError& e) {
  if (!e.measured()) return "";
  std::ostringstream line;
  line << "error:        displacement error at most " << 100.0 * e.relative
       << " % of its tolerance: vertex " << e.vertex << ", " << e.error << " m against the step's truncation error "
       << e.truncation << " m there (tolerance " << e.tolerance << " m); largest " << e.largest << " m\n";
  return line.str();
}

/// Where the implicit solves' time went (NewtonTimes), labelled by the solver the scene chose
/// (integrator.solver): Newton's alone; or L-BFGS's with the Newton iterations that check its
/// solutions and finish its fallbacks, whose times the step reports sum with its own.
std::string solverTimeLine(const StepTotals& totals, bool lbfgs) {
  const NewtonTimes& t = totals.newtonTimes;
  const std::uint64_t iterations = totals.newtonIterations + totals.quasiNewtonIterations;
  const double total = t.total();
  if (iterations == 0 || !(total > 0.0)) return "";
  auto share = [&](double part) { return std::lround(100.0 * part / total); };
  std::ostringstream line;
  line << (lbfgs ? "L-BFGS time:  " : "Newton time:  ") << total << " s"
       << (lbfgs ? " (Newton's check and fallbacks included)" : "") << ", "
       << 1e3 * total / static_cast<double>(iterations) << " ms per iteration"
       << (lbfgs ? " of either" : "") << ": assembly " << share(t.assembly) << " %, factorisation "
       << share(t.factorisation) << " %, solve " << share(t.solve) << " %, step bound "
       << share(t.bound) << " %, line search " << share(t.search) << " %\n";
  return line.str();
}

class Progress {
 public:
  Progress(double duration, bool enabled)
      : duration_(duration), enabled_(enabled), tty_(isatty(STDERR_FILENO) != 0),
        start_(std::chrono::steady_clock::now()), last_(start_) {}
  void update(double t, std::uint64_t steps) {
    if (!enabled_) return;
    const auto now = std::chrono::steady_clock::now();
    if (std::chrono::duration<double>(now - last_).count() < (tty_ ? 0.5 : 5.0)) return;
    last_ = now;
    const double wall = std::chrono::duration<double>(now - start_).count();
    const double fraction = std::min(t / duration_, 1.0);
    const double eta = fraction > 0 ? wall * (1.0 - fraction) / fraction : 0.0;
    std::fprintf(stderr, "%sprogress: t = %.3f / %.3f s (%3.0f%%), %llu steps, %.1f steps/s, ETA %.0f s%s",
                 tty_ ? "\r" : "", t, duration_, 100 * fraction,
                 static_cast<unsigned long long>(steps), steps / std::max(wall, 1e-9), eta,
                 tty_ ? "   " : "\n");
    dirty_ = tty_;
  }
  void finish() {
    if (dirty_) std::fprintf(stderr, "\n");
  }

 private:
  double duration_;
  bool enabled_, tty_, dirty_ = false;
  std::chrono::steady_clock::time_point start_, last_;
};

void writeFrame(std::ostream& trajectory, const Simulator& sim) {
  const State& s = sim.state();
  trajectory << std::setprecision(17) << s.time << ',' << s.step;
  for (Eigen::Index i = 0; i < s.x.size(); ++i) trajectory << ',' << s.x[i];
  trajectory << '\n';
}

void writeEnergy(std::ostream& energy, Simulator& sim, const EdgeStretch& stretch, double minJ) {
  const EnergyReport e = sim.energies();
  const StepReport& r = sim.lastReport();
  energy << std::setprecision(12) << sim.time() << ',' << sim.state().step << ',' << e.kinetic
         << ',' << e.strain << ',' << e.bending << ',' << e.gravity << ',' << e.externalWork << ','
         << e.pinWork << ',' << e.contactWork << ',' << e.airWork << ',' << e.liveWork << ','
         << e.dissipated << ',' << e.total << ',' << e.balanceError << ','
         << stretch.mean << ',' << stretch.max << ',' << minJ << ',' << r.substeps << ','
         << r.newtonIterations << ',' << r.residual << ',' << r.lineSearchBacktracks << ','
         << r.rollbacks << '\n';
}

// A small text output (--write-scene, --summary-json): never one of the inputs, and complete
// under its name or absent (OutputFile).
bool writeTextFile(const std::string& path, const std::string& text, const std::vector<std::string>& inputs) {
  Status written = checkNotAnInput(path, inputs);
  if (written) {
    Expected<std::unique_ptr<OutputFile>> file = OutputFile::open(path);
    if (file) {
      (*file)->stream() << text;
      written = (*file)->commit();
    } else {
      written = Error{file.error()};
    }
  }
  if (!written) std::cerr << "fem_cloth_sim: " << oneLine(written.error()) << '\n';
  return static_cast<bool>(written);
}

// --summary-json: the summary for programs, in SI units (J, s); state_hash is ClothState's hash
// of the final positions and velocities (equal hashes: bit-identical states). Non-finite
// numbers become null.
using Json = nlohmann::ordered_json;

Json energyJson(const EnergyReport& e) {
  return Json{{"kinetic", e.kinetic},         {"strain", e.strain},
              {"bending", e.bending},         {"gravity", e.gravity},
              {"contact_energy", e.contactEnergy},
              {"total", e.total},             {"external_work", e.externalWork},
              {"pin_work", e.pinWork},        {"contact_work", e.contactWork},
              {"air_work", e.airWork},        {"live_work", e.liveWork},
              {"dissipated", e.dissipated},   {"initial_total", e.initialTotal},
              {"balance_error", e.balanceError}};
}

// The energy balance as both summaries judge it (judgeBalance, acceptance (b) over the run), and
// the steps flagged as pin jumps (Simulator::kPinJumpWork).
Json balanceJson(const EnergyReport& e, const BalanceJudgement& b) {
  return Json{{"created", b.created}, {"energy_scale", b.scale}, {"fraction", b.fraction()},
              {"tolerance", b.tolerance}, {"ok", b.ok()}, {"pin_jumps", e.pinJumps}};
}

// "failed" (the run stopped at an error), "warning" (it ran to the end, but its energy balance is
// out of tolerance, pins yanked the cloth, or its surface reached into a box) or "ok".
const char* runStatus(const std::string& failure, const EnergyReport& e, const BalanceJudgement& b,
                      bool intoBox = false) {
  return !failure.empty() ? "failed" : (b.ok() && e.pinJumps == 0 && !intoBox) ? "ok" : "warning";
}

// The summary's line, and the warning, when the cloth's surface reached into a box between its
// vertices, or with the explicit steppers into any obstacle (docs/contact.md, Limits). The
// projection of the explicit steppers keeps vertices out and measures it exactly; the barriers'
// contact model keeps the surface out and measures a lower bound for boxes.
std::string boxDepthText(const StepTotals& t, const std::string& integrator) {
  const Expected<const IntegratorEntry*> entry = findIntegrator(integrator);
  const bool exact = entry && (*entry)->supports.contact == ContactMethod::Projection;
  std::ostringstream text;
  text << std::setprecision(3) << "the cloth's surface reached " << 1e3 * t.boxDepth << " mm into " << t.boxDepthWhere
       << " between its vertices (step " << t.boxDepthStep
       << (exact ? "; exact: every triangle after every substep" : "; at least: a grid of points per triangle")
       << (exact ? "): the explicit steppers keep vertices out of obstacles, not edges and triangles"
                 : "): the box barriers were bypassed")
       << " (docs/contact.md, Limits)";
  return text.str();
}

// The summaries' work line: every work term of the balance (EnergyReport), so that the balance
// error is recomputable from the summary (and from ClothEnergy) alone.
std::string workLine(const EnergyReport& e) {
  std::ostringstream line;
  line << std::setprecision(4) << "work (J):     external " << e.externalWork << ", pins " << e.pinWork << ", contact "
       << e.contactWork << " (by moving obstacles, measured, friction included), air " << e.airWork
       << ", live changes " << e.liveWork << ", dissipated by damping and friction " << e.dissipated << '\n';
  return line.str();
}

// The summaries' balance line: the judgement, and what of the loss is the scheme's (expected);
// and the pin jumps, if any.
std::string balanceLine(const EnergyReport& e, const BalanceJudgement& b) {
  std::ostringstream line;
  line << std::setprecision(4) << "balance:      " << b.text() << "; numerical dissipation "
       << e.numericalDissipation << " J = " << 100.0 * e.numericalDissipation / b.scale
       << " % (the scheme's expected loss, not an error); balance error " << e.balanceError << " J\n";
  if (e.pinJumps > 0) {
    line << "pin jumps:    " << e.pinJumps << (e.pinJumps == 1 ? " step" : " steps")
         << " whose pins yanked the cloth (more work in one step than its energy scale; the warnings name them)\n";
  }
  return line.str();
}

// One warning line on stderr when the balance is out of tolerance.
void warnAboutBalance(const BalanceJudgement& b) {
  if (!b.ok()) std::cerr << "fem_cloth_sim: warning: " << oneLine(b.warning()) << '\n';
}

bool writeSummaryJson(const Options& opt, const Json& summary) {
  return opt.summaryJson.empty() ||
         writeTextFile(opt.summaryJson, summary.dump(2) + "\n", {opt.scene, opt.commands, opt.out});
}

// A scene file with its overrides applied, parsed and built as a run would build it.
struct Loaded {
  YAML::Node document;
  Scene scene;
  Simulation simulation;
};

Expected<Loaded> loadAndBuild(const std::string& path, const std::vector<std::string>& overrides) {
  YAML::Node document;
  Expected<Scene> scene = loadScene(path, overrides, &document);
  if (!scene) return Error{scene.error()};
  Expected<Simulation> built = buildSimulation(*scene);
  if (!built) return Error{path + ": " + built.error()};
  return Loaded{document, std::move(scene).value(), std::move(built).value()};
}

// --check and --write-scene: the scene is validated exactly as a run would build it, without
// stepping; --write-scene saves the document with the overrides applied, so that the run repeats
// with `--scene FILE` alone (fem_cloth_batch writes its episodes this way).
int checkScene(const Options& opt, const std::vector<std::string>& overrides) {
  Expected<Loaded> loaded = loadAndBuild(opt.scene, overrides);
  if (!loaded) {
    std::cerr << "fem_cloth_sim: " << oneLine(loaded.error()) << '\n';
    return 2;
  }
  if (!opt.writeScene.empty() &&
      !writeTextFile(opt.writeScene, sceneDocumentToString(loaded->document) + "\n",
                     {opt.scene, meshFilePath(loaded->scene)})) {
    return 2;
  }
  if (opt.check) {
    const Scene& s = loaded->scene;
    for (const std::string& w : s.warnings) std::cerr << "fem_cloth_sim: warning: " << oneLine(w) << '\n';
    const Simulator& simulator = *loaded->simulation.simulator;
    std::cout << "scene ok:     " << s.name << " (" << opt.scene << "), "
              << simulator.model().numVertices() << " vertices, "
              << simulator.model().mesh().numTriangles() << " triangles, "
              << simulator.integrator().name() << ", dt " << s.dt << " s, duration "
              << s.duration << " s\n";
  }
  return 0;
}

// The summaries' lines on the steps (StepTotals) of a run with `integrator`: its solver's work, for
// the implicit steppers where their solves' time went (by `lbfgs`, the solver chosen) and their
// worst error; how deep the cloth's surface reached into a box, if it did. A scene run and a run
// into a bag print the same.
std::string solverLines(const StepTotals& totals, const std::string& integrator, bool lbfgs) {
  std::ostringstream lines;
  lines << std::setprecision(4);
  auto perStep = [&](std::uint64_t count) {
    return totals.steps ? static_cast<double>(count) / static_cast<double>(totals.steps) : 0.0;
  };
  if (integrator == "xpbd" || integrator == "projective_dynamics") {
    lines << "solver:       " << totals.localIterations << " "
          << (integrator == "xpbd" ? "constraint sweeps" : "local/global iterations")
          << " (" << perStep(totals.localIterations) << " per step), " << totals.substeps
          << " substeps, " << totals.rollbacks << " rollbacks, " << totals.failures << " failures\n";
  } else if (integrator == "symplectic_euler") {
    lines << "solver:       explicit, " << totals.substeps << " substeps (" << perStep(totals.substeps)
          << " per step), " << totals.rollbacks << " rollbacks, " << totals.failures << " failures\n";
  } else {
    // The implicit steppers (backward_euler, bdf2): their solver.
    lines << "solver:       ";
    if (lbfgs) {
      lines << totals.quasiNewtonIterations << " L-BFGS iterations (" << perStep(totals.quasiNewtonIterations)
            << " per step), " << totals.solverFallbacks << " substeps fell back to Newton, ";
    }
    lines << totals.newtonIterations << " Newton iterations ("
          << perStep(totals.newtonIterations) << " per step), max residual " << totals.maxResidual
          << " N, " << totals.backtracks << " line-search backtracks, " << totals.rollbacks << " rollbacks";
    if (totals.tightened > 0) lines << " (" << totals.tightened << " re-solved 100x tighter)";
    lines << ", " << totals.failures << " failures\n";
    lines << solverTimeLine(totals, lbfgs);
  }
  lines << errorLine(totals.worstError);
  if (totals.boxDepth > 0.0) lines << "surface:      " << boxDepthText(totals, integrator) << '\n';
  return lines.str();
}

// The worst displacement error of the accepted steps (m; null when not measured).
Json displacementErrorJson(const DisplacementError& e) {
  if (!e.measured()) return nullptr;
  return Json{{"relative", e.relative}, {"error", e.error}, {"truncation", e.truncation},
              {"tolerance", e.tolerance}, {"vertex", e.vertex}, {"largest", e.largest}};
}

// Re-simulation of a recorded run, or a scene, into a bag.
int runBag(const Options& opt, const std::vector<std::string>& overrides) {
  BagRunOptions options;
  options.node = opt.node;
  options.sceneFile = opt.scene;
  options.overrides = overrides;
  options.duration = opt.duration;
  options.every = opt.every;
  options.progress = !opt.quiet;
  Expected<BagRunReport> report = runToBag(opt.commands, opt.out, options);
  if (!report) {
    std::cerr << "fem_cloth_sim: " << oneLine(report.error()) << '\n';
    return 2;
  }
  const BagRunReport& r = *report;
  for (const std::string& w : r.warnings) std::cerr << "fem_cloth_sim: warning: " << oneLine(w) << '\n';
  std::cout << std::setprecision(4);
  std::cout << "scene:        " << r.scene << ", " << r.integrator << '\n';
  if (!opt.commands.empty()) {
    std::cout << "commands:     ";
    for (fem_cloth::CommandTopic topic : fem_cloth::commandTopics()) {
      std::cout << r.commands[static_cast<std::size_t>(topic)] << ' ' << fem_cloth::topicName(topic) << ", ";
    }
    std::cout << "from "
              << opt.commands << " ("
              << (r.exactCommands ? "as applied by the node: exact steps"
                                  : "as sent: applied at the step after they were recorded")
              << "), " << r.rejected << " rejected\n";
  }
  std::cout << "steps:        " << r.steps << " (" << r.stepTotals.substeps << " substeps), simulated " << r.simulated
            << " s in " << r.wall << " s wall (real-time factor " << r.simulated / std::max(r.wall, 1e-9) << ")\n";
  if (r.compared > 0) {
    std::cout << "reproduced:   " << r.identical << " of " << r.compared
              << " recorded states bit for bit";
    std::cout << "; largest difference: positions " << r.maxPositionDifference << " m";
    if (r.maxVelocityDifference > 0.0) std::cout << ", velocities " << r.maxVelocityDifference << " m/s";
    if (!r.firstDifference.empty()) std::cout << "; first difference: " << oneLine(r.firstDifference);
    std::cout << '\n';
  }
  std::cout << "energy (J):   kinetic " << r.energy.kinetic << ", strain " << r.energy.strain
            << ", bending " << r.energy.bending << ", gravity " << r.energy.gravity << ", total "
            << r.energy.total << " (at the start " << r.energy.initialTotal << ")\n";
  std::cout << workLine(r.energy);
  const BalanceJudgement& balance = r.balance;
  std::cout << balanceLine(r.energy, balance);
  std::cout << solverLines(r.stepTotals, r.integrator, r.lbfgs);
  std::cout << "digest:       " << r.finalHash << " (state hash of the final state)\n";
  warnAboutBalance(balance);
  if (r.stepTotals.boxDepth > 0.0) std::cerr << "fem_cloth_sim: warning: " << oneLine(boxDepthText(r.stepTotals, r.integrator)) << '\n';
  const Json summary{{"status", runStatus(r.failure, r.energy, balance, r.stepTotals.boxDepth > 0.0)},
                     {"error", r.failure},
                     {"scene", r.scene},
                     {"integrator", r.integrator},
                     {"steps", r.steps},
                     {"simulated_s", r.simulated},
                     {"wall_s", r.wall},
                     {"energy", energyJson(r.energy)},
                     {"balance", balanceJson(r.energy, balance)},
                     {"stretch", {{"mean", r.stretch.mean}, {"max", r.stretch.max}}},
                     {"max_residual", r.stepTotals.maxResidual},
                     {"displacement_error", displacementErrorJson(r.stepTotals.worstError)},
                     {"box_depth", r.stepTotals.boxDepth},
                     {"state_hash", r.finalHash},
                     {"outputs", r.failure.empty() && !opt.out.empty() ? Json::array({opt.out}) : Json::array()}};
  if (!writeSummaryJson(opt, summary)) return 2;
  if (!r.failure.empty()) {
    std::cerr << "fem_cloth_sim: " << oneLine(r.failure) << "; no bag was written\n";
    return 3;
  }
  std::cout << "output:       " << (opt.out.empty() ? "none (no --out)" : opt.out) << '\n';
  if (opt.verify && r.identical < r.compared) {
    std::cerr << "fem_cloth_sim: --verify: " << (r.compared - r.identical) << " of " << r.compared
              << " recorded states were not reproduced bit for bit; the first is "
              << oneLine(r.firstDifference) << "; the largest position difference is "
              << numberText(r.maxPositionDifference) << " m";
    if (r.maxVelocityDifference > 0.0) {
      std::cerr << ", the largest velocity difference " << numberText(r.maxVelocityDifference) << " m/s";
    }
    std::cerr << '\n';
    return 4;
  }
  if (opt.verify && r.compared == 0) {
    std::cerr << "fem_cloth_sim: --verify: the input bag has no states to compare with\n";
    return 4;
  }
  return 0;
}

// trajectory.csv and energy.csv in the output folder, with their header lines.
struct CsvOutputs {
  std::string folder;
  std::unique_ptr<OutputFile> trajectory, energy;
};

Expected<CsvOutputs> openCsvOutputs(const Options& opt, const Scene& scene, const Simulator& simulator) {
  CsvOutputs out;
  // The default folder is named after the scene: a word (validateScene), so it stays inside
  // fem_cloth_output.
  out.folder = opt.out.empty() ? "fem_cloth_output/" + scene.name : opt.out;
  std::error_code ec;
  std::filesystem::create_directories(out.folder, ec);
  if (ec) return Error{"cannot create output folder '" + out.folder + "': " + ec.message()};
  const std::vector<std::string> inputs = {opt.scene, meshFilePath(scene)};
  for (auto [file, name] : {std::pair{&out.trajectory, "trajectory.csv"}, std::pair{&out.energy, "energy.csv"}}) {
    const std::string path = out.folder + "/" + name;
    FEM_CLOTH_CHECK(checkNotAnInput(path, inputs));
    Expected<std::unique_ptr<OutputFile>> opened = OutputFile::open(path);
    if (!opened) return Error{opened.error()};
    *file = std::move(opened).value();
  }
  std::ostream& trajectory = out.trajectory->stream();
  trajectory << "time,step";
  const char* axes = "xyz";
  for (Index i = 0; i < simulator.model().numVertices(); ++i) {
    for (int k = 0; k < simulator.dim(); ++k) trajectory << ',' << axes[k] << i;
  }
  trajectory << '\n';
  out.energy->stream() << "time,step,kinetic,strain,bending,gravity,external_work,pin_work,contact_work,"
                          "air_work,live_work,dissipated,total,balance_error,mean_stretch,max_stretch,min_area_ratio,substeps,newton_iterations,"
                          "residual,backtracks,rollbacks\n";
  return out;
}

void printSummary(const Options& opt, const Scene& scene, Simulator& simulator, const Totals& totals,
                  std::uint64_t totalSteps, double wall,
                  const EdgeStretch& st, const std::string& outDir) {
  const EnergyReport e = simulator.energies();
  const BalanceJudgement balance = simulator.balance(e);
  std::ostringstream summary;
  summary << std::setprecision(4);
  summary << "scene:        " << scene.name << " (" << opt.scene << "), "
          << simulator.model().numVertices() << " vertices, " << simulator.model().mesh().numTriangles()
          << " triangles, model " << scene.materialModel << '\n';
  summary << "integrator:   " << simulator.integrator().name() << ", dt " << scene.dt << " s";
  // Their iterations are local sweeps (XPBD) or local/global iterations (PD), not Newton's.
  const bool iteratesLocally = scene.integrator == "xpbd" || scene.integrator == "projective_dynamics";
  if (iteratesLocally) {
    summary << ", " << scene.iterations << " iterations";
  }
  summary << '\n';
  summary << "steps:        " << totals.steps << " of " << totalSteps << " (" << totals.substeps
          << " substeps), simulated " << simulator.time() << " s in " << wall << " s wall"
          << " (real-time factor " << simulator.time() / std::max(wall, 1e-9) << ")\n";
  summary << "energy (J):   kinetic " << e.kinetic << ", strain " << e.strain << ", bending "
          << e.bending << ", gravity " << e.gravity << ", contact barriers " << e.contactEnergy
          << ", total " << e.total << '\n';
  summary << workLine(e);
  if (const ObstacleSet* obstacles = simulator.obstacles()) {
    // What each obstacle carries at the end (N, in the simulation frame): a table under a
    // resting cloth carries its weight.
    const StepReport& last = simulator.lastReport();
    summary << "contact:      " << last.contacts << " contacts at the end, closest "
            << last.minContactDistance << " m, work " << e.contactWork << " J";
    for (std::size_t k = 0; k < obstacles->size(); ++k) {
      const Eigen::Vector3d f = obstacles->wrenches()[k].force;
      summary << "; '" << (*obstacles)[k].name << "' feels [" << f.x() << ", " << f.y() << ", "
              << f.z() << "] N";
    }
    summary << '\n';
  }
  // What is an error and what is expected (issue 11): energy the steps created, net, is the
  // error, bounded by acceptance (b) at a fraction of the run's energy scale; what the scheme
  // lost beyond the damping model is numerical dissipation, expected of the implicit schemes.
  summary << balanceLine(e, balance);
  summary << "stretch:      mean " << 100.0 * st.mean << " %, max " << 100.0 * st.max
          << " % (max over the run " << 100.0 * totals.maxStretch << " %)\n";
  summary << "min J:        " << totals.minAreaRatio << " (smallest deformed/rest area ratio seen)\n";
  summary << solverLines(totals, scene.integrator, solvesByLbfgs(simulator.integrator()));
  if (!outDir.empty()) summary << "outputs:      " << outDir << "/trajectory.csv, " << outDir << "/energy.csv\n";
  std::cout << summary.str();
  warnAboutBalance(balance);
  if (totals.boxDepth > 0.0) {
    std::cerr << "fem_cloth_sim: warning: " << oneLine(boxDepthText(totals, simulator.integrator().name())) << '\n';
  }
}

// Watches a run after every step: the smallest area ratio and the largest stretch so far, and on
// request a frame of trajectory.csv and energy.csv (none with --no-output: outputs null).
struct Observer {
  Simulator& simulator;
  const EdgeStretchMeter& stretchMeter;
  Totals& totals;
  CsvOutputs* outputs;

  void operator()(bool write) const {
    const EdgeStretch st = stretchMeter.measure(simulator.state().x);
    const double minJ = minAreaRatio(simulator.model().mesh(), simulator.model().rest(), simulator.state().x);
    totals.minAreaRatio = std::min(totals.minAreaRatio, minJ);
    totals.maxStretch = std::max(totals.maxStretch, st.max);
    if (write && outputs != nullptr) {
      writeFrame(outputs->trajectory->stream(), simulator);
      writeEnergy(outputs->energy->stream(), simulator, st, minJ);
    }
  }
};

// What stepping a scene to its end did: the error it stopped at (empty: none) and the wall time
// of the steps (s).
struct Stepped {
  std::string failure;
  double wall = 0.0;
};

// Steps the scene `totalSteps` times, or up to its first failure (a script command or a step that
// failed), writing a frame every `every` steps and after the last.
Stepped stepToEnd(Simulation& sim, const Scene& scene, std::uint64_t totalSteps, int every,
                  const Observer& observe, Totals& totals, bool quiet) {
  Simulator& simulator = *sim.simulator;
  Stepped out;
  Progress progress(scene.duration, !quiet);
  const auto wallStart = std::chrono::steady_clock::now();
  for (std::uint64_t k = 0; k < totalSteps; ++k) {
    if (Status s = sim.script.applyDue(simulator); !s) {
      out.failure = s.error();
      break;
    }
    const StepReport r = simulator.step();
    if (!r.ok) {
      totals.addFailure(r);
      out.failure = r.error;
      break;
    }
    if (!r.warning.empty()) std::cerr << "fem_cloth_sim: warning: " << oneLine(r.warning) << '\n';
    totals.addStep(r);
    observe((k + 1) % static_cast<std::uint64_t>(every) == 0 || k + 1 == totalSteps);
    progress.update(simulator.time(), totals.steps);
  }
  out.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wallStart).count();
  progress.finish();
  return out;
}

// The summary of a scene run for --summary-json.
Json sceneRunJson(const Scene& scene, Simulator& simulator, const Totals& totals, std::uint64_t totalSteps,
                  const Stepped& stepped, const EdgeStretch& st, const Json& files) {
  const EnergyReport e = simulator.energies();
  const BalanceJudgement balance = simulator.balance(e);
  return Json{{"status", runStatus(stepped.failure, e, balance, totals.boxDepth > 0.0)},
              {"error", stepped.failure},
              {"scene", scene.name},
              {"integrator", simulator.integrator().name()},
              {"steps", totals.steps},
              {"total_steps", totalSteps},
              {"simulated_s", simulator.time()},
              {"wall_s", stepped.wall},
              {"energy", energyJson(e)},
              {"balance", balanceJson(e, balance)},
              {"stretch", {{"mean", st.mean}, {"max", st.max}, {"max_over_run", totals.maxStretch}}},
              {"min_area_ratio", totals.minAreaRatio},
              {"max_residual", totals.maxResidual},
              {"displacement_error", displacementErrorJson(totals.worstError)},
              {"box_depth", totals.boxDepth},
              {"state_hash", stateHash(simulator.state().x, simulator.state().v)},
              {"outputs", files}};
}

// A scene run headless into CSV files (or none).
int runScene(const Options& opt, const std::vector<std::string>& overrides) {
  Expected<Loaded> loaded = loadAndBuild(opt.scene, overrides);
  if (!loaded) {
    std::cerr << "fem_cloth_sim: " << oneLine(loaded.error()) << '\n';
    return 2;
  }
  const Scene& scene = loaded->scene;
  Simulation& sim = loaded->simulation;
  for (const std::string& w : scene.warnings) std::cerr << "fem_cloth_sim: warning: " << oneLine(w) << '\n';
  for (const std::string& w : sim.warnings) std::cerr << "fem_cloth_sim: warning: " << oneLine(w) << '\n';
  Simulator& simulator = *sim.simulator;
  const double dt = scene.dt;
  const std::uint64_t totalSteps =
      static_cast<std::uint64_t>(std::llround(std::ceil(scene.duration / dt - 1e-9)));
  const int every = opt.every > 0 ? opt.every : std::max(1, static_cast<int>(std::lround(1.0 / (60.0 * dt))));

  CsvOutputs outputs;
  if (!opt.noOutput) {
    Expected<CsvOutputs> opened = openCsvOutputs(opt, scene, simulator);
    if (!opened) {
      std::cerr << "fem_cloth_sim: " << oneLine(opened.error()) << '\n';
      return 2;
    }
    outputs = std::move(opened).value();
  }
  const EdgeStretchMeter stretchMeter(*sim.mesh);
  Totals totals;
  const Observer observe{simulator, stretchMeter, totals, opt.noOutput ? nullptr : &outputs};
  observe(true);
  const Stepped stepped = stepToEnd(sim, scene, totalSteps, every, observe, totals, opt.quiet);
  if (!opt.noOutput && !stepped.failure.empty()) observe(true);
  // The outputs hold the run up to its last good state, also when it failed.
  if (!opt.noOutput) {
    for (OutputFile* file : {outputs.trajectory.get(), outputs.energy.get()}) {
      if (Status s = file->commit(); !s) {
        std::cerr << "fem_cloth_sim: " << oneLine(s.error()) << '\n';
        return 2;
      }
    }
  }
  const EdgeStretch st = stretchMeter.measure(simulator.state().x);
  printSummary(opt, scene, simulator, totals, totalSteps, stepped.wall, st, outputs.folder);
  Json files = Json::array();
  if (!opt.noOutput) files = {outputs.folder + "/trajectory.csv", outputs.folder + "/energy.csv"};
  if (!writeSummaryJson(opt, sceneRunJson(scene, simulator, totals, totalSteps, stepped, st, files))) return 2;
  if (!stepped.failure.empty()) {
    std::cerr << "fem_cloth_sim: simulation failed at t = " << simulator.time() << " s: "
              << oneLine(stepped.failure) << '\n';
    return 3;
  }
  return 0;
}

// The scene overrides: --set's, then --integrator's, --dt's and --duration's (a re-simulation
// runs for the recording's duration unless --duration: runToBag takes it itself).
std::vector<std::string> sceneOverrides(const Options& opt) {
  std::vector<std::string> overrides = opt.overrides;
  if (!opt.integrator.empty()) overrides.push_back("integrator.name=" + opt.integrator);
  if (opt.dt != 0.0) {
    std::ostringstream s;
    s << std::setprecision(17) << "integrator.dt=" << opt.dt;
    overrides.push_back(s.str());
  }
  if (opt.duration != 0.0 && opt.commands.empty()) {
    std::ostringstream s;
    s << std::setprecision(17) << "duration=" << opt.duration;
    overrides.push_back(s.str());
  }
  return overrides;
}

// The parsed command line: its combinations checked, then a scene check, a bag run or a scene run.
int runParsed(const Options& opt) {
  const std::vector<std::string> overrides = sceneOverrides(opt);
  if (opt.commands.empty() && opt.scene.empty()) {
    std::cerr << "fem_cloth_sim: --scene is required (or --commands BAG; see --help)\n";
    return 2;
  }
  if ((opt.check || !opt.writeScene.empty()) && (opt.scene.empty() || !opt.commands.empty())) {
    std::cerr << "fem_cloth_sim: --check and --write-scene need --scene (and no --commands)\n";
    return 2;
  }
  // Before the run, not after it: a --summary-json naming the recording would be refused only
  // once the replay is done.
  for (const auto& [option, out] : {std::pair{"--write-scene", &opt.writeScene}, std::pair{"--summary-json", &opt.summaryJson}}) {
    if (out->empty()) continue;
    Status s = checkNotAnInput(*out, {opt.scene, opt.commands});
    if (s) s = checkOutputPath(*out);
    if (!s) {
      std::cerr << "fem_cloth_sim: " << option << ": " << oneLine(s.error()) << '\n';
      return 2;
    }
    // Nor another output of the run: found now, not when the run's bag has taken the name.
    if (!opt.out.empty() && sameOutputPath(*out, opt.out)) {
      std::cerr << "fem_cloth_sim: " << option << " '" << *out << "' is the --out '" << opt.out
                << "': give another file\n";
      return 2;
    }
  }
  if (!opt.writeScene.empty() && !opt.summaryJson.empty() && sameOutputPath(opt.writeScene, opt.summaryJson)) {
    std::cerr << "fem_cloth_sim: --write-scene and --summary-json name the same file '" << opt.summaryJson
              << "': give two files\n";
    return 2;
  }
  if (!opt.writeScene.empty() || opt.check) {
    if (int status = checkScene(opt, overrides); status != 0 || opt.check) return status;
  }
  const bool bagOut = opt.out.size() > 4 && opt.out.compare(opt.out.size() - 4, 4, ".bag") == 0;
  if (!opt.commands.empty() || bagOut) {
    // Without --out a re-simulation only compares and summarises (--verify): no bag written.
    if (!bagOut && !opt.out.empty()) {
      std::cerr << "fem_cloth_sim: --commands writes a bag: give --out FILE.bag (or no --out)\n";
      return 2;
    }
    return runBag(opt, overrides);
  }
  return runScene(opt, overrides);
}

// The integrators and what each supports, from the integrator registry.
std::string integratorHelp() {
  std::ostringstream text;
  text << "Integrators (integrator.name):\n";
  for (const IntegratorEntry& e : integratorRegistry()) {
    text << "  " << e.name << ": " << e.summary << "\n      " << capabilitiesText(e.supports) << '\n';
  }
  return text.str();
}

int run(int argc, char** argv) {
  Options opt;
  CLI::App app{
      "Runs a fem_cloth scene headless (no ROS master needed) and prints a summary.\n"
      "Writes trajectory.csv (time, step, then x y [z] of every vertex) and energy.csv\n"
      "(energies in J, stretch, solver statistics) to the output folder."};
  app.add_option("--scene", opt.scene,
                 "scene YAML file (see docs/scenes.md); with --commands, replaces the scene "
                 "stored in the bag");
  std::string integratorList;
  for (const std::string& name : integratorNames()) integratorList += (integratorList.empty() ? "" : ", ") + name;
  app.add_option("--integrator", opt.integrator,
                 "override integrator.name: " + integratorList + " (see below)");
  app.add_option("--dt", opt.dt, "override integrator.dt (s)");
  // Checked here for --commands too, where no scene key takes it (a replay ignored -1).
  app.add_option("--duration", opt.duration, "override the scene's duration (s)")->check(positiveNumber());
  app.add_option("--set", opt.overrides, "override any scene key: key.path=value (repeatable)");
  app.add_option("--out", opt.out,
                 "output folder for CSV (default: fem_cloth_output/<scene name>), or a file "
                 "ending in .bag to write a bag (~scene, ~mesh, ~state, ~energy, ~stats)");
  app.add_option("--commands", opt.commands,
                 "re-simulate a recorded run: apply its commands (applied_pin/applied_force, "
                 "else pin/force) at their stamps, follow its /tf; writes --out FILE.bag if given");
  app.add_option("--node", opt.node, "the node whose topics the bags hold (/fem_cloth_node)");
  app.add_flag("--verify", opt.verify,
               "with --commands: exit 4 unless every recorded state is reproduced bit for bit "
               "(positions, velocities where recorded, state hash); a damaged recorded state "
               "(not finite, not one position per vertex) is refused with status 2");
  app.add_flag("--no-output", opt.noOutput, "write no files, only the summary");
  app.add_option("--every", opt.every, "write every N-th step (default: about 60 frames per s)")
      ->check(positiveNumber());
  app.add_flag("--quiet,-q", opt.quiet, "no progress line");
  app.add_flag("--check", opt.check,
               "validate the scene with its overrides (parse and build it), print one line and "
               "exit without running: 0 valid, 2 not");
  app.add_option("--summary-json", opt.summaryJson,
                 "also write the summary as JSON to this file (status ok, warning or failed; "
                 "energies, the energy balance as judged, stretch, final state hash; on a failed "
                 "run the state reached and the error). warning: the run ended, but its energy "
                 "balance is out of tolerance, pins jumped, or the cloth's surface reached into a box "
                 "between its vertices (the exit status is still 0)");
  app.add_option("--write-scene", opt.writeScene,
                 "write the scene with the --set overrides applied to this YAML file (runs "
                 "again with --scene FILE alone)");
  app.footer(integratorHelp());
  if (const std::optional<int> status = fem_cloth::parseToolCommandLine(app, argc, argv, "fem_cloth_sim")) {
    return *status;
  }

  return runParsed(opt);
}

}  // namespace

int main(int argc, char** argv) {
  fem_cloth::preferPassiveThreadWaiting(argv);
  // Every error is meant to come back as a value with a message; this is the last line of
  // defence, so that even an unforeseen exception is one line and an exit status, not an abort.
  try {
    return run(argc, argv);
  } catch (const YAML::Exception& e) {
    std::cerr << "fem_cloth_sim: bad input: " << oneLine(e.what()) << '\n';
    return 2;
  } catch (const std::bad_alloc&) {
    std::cerr << "fem_cloth_sim: out of memory\n";
    return 3;
  } catch (const std::exception& e) {
    std::cerr << "fem_cloth_sim: internal error: " << oneLine(e.what()) << '\n';
    return 3;
  }
}
