// fem_cloth_report: the accuracy and stability report (docs/accuracy.md).
//
//   fem_cloth_report [--out DIR] [--cache DIR] [--small] [--study all|work-precision|stability]
//                    [--integrators a,b] [--scenes a,b] [--cases a,b] [--materials a,b]
//
// Work precision: every integrator (integratorNames(), so new ones join automatically) on the
// standard scenes over a range of time steps and settings; wall time of the steps (median of
// repeats) and the error against a much finer BDF2 run (cached on disk, keyed by the scene text)
// at matched times, relative to the cloth size. Convergence orders from the error against dt.
// Stability: material x stretch stiffness x integrator x dt x extreme case, each cell classified
// stable / recovered (rollbacks) / failed (with the error) / n/a (the integrator refuses the
// material or mesh at load: projective dynamics takes ARAP cloth only) / too slow (over the
// cell's wall-time budget) / non-finite (a bug: must never happen).
//
// Writes CSV files to --out (scripts/report plots them): work_precision.csv, error_over_time.csv,
// references.csv, orders.csv, targets.csv, stability.csv and summary.txt (also printed), and
// every scene it runs to scenes/*.yaml (fem_cloth_sim --scene runs any of them by hand).
// The stability cells run here one after the other, or as tasks of fem_cloth_batch's runner on
// Dask (scripts/report): --list-cells, --cells FIRST:LAST --cell-results FILE for each task, then
// --from-cell-results DIR for the report itself.
// Exit status: 0 done, 2 bad command line or inputs, 3 a reference run failed, 4 a cell or run
// was non-finite.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>

#include "fem_cloth/core/materials/materials.h"
#include "fem_cloth/core/package_paths.h"
#include "fem_cloth/core/scene.h"
#include "fem_cloth/io/command_line.h"
#include "fem_cloth/io/output_file.h"
#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/report/cases.h"
#include "fem_cloth/report/run.h"
#include "fem_cloth/report/stability.h"
#include "fem_cloth/ros/bag_replay.h"

using namespace fem_cloth;
using namespace fem_cloth::report;

namespace {

struct Options {
  std::string out = "output/report";
  std::string cache;  // default: <out>/cache
  std::string configDir;  // default: the package's config/ (findPackageFile)
  std::string bag;        // default: the package's test/data/small_grasp.bag
  std::shared_ptr<const Recording> recording;  // the bag, read (null: none, or it failed)
  std::string recordingError;
  bool small = false;
  std::string study = "all";
  std::vector<std::string> integrators, scenes, cases, materials, stiffness;
  std::vector<double> dts;  // stability: only these steps
  std::vector<std::string> overrides;  // work precision: key=value on every scene
  std::string listCells;        // stability: write the cells of the selection (JSON) and stop
  std::string cellRange;        // stability: run only cells FIRST:LAST ...
  std::string cellResults;      // ... and write their results here (JSON), nothing else
  std::string fromCellResults;  // stability: the cells' results from this folder, not run here
  int repeats = 3;
  double repeatBudget = 2.0;          // s: no further repeats once a setting has run this long
  double referenceResolution = 0.25;  // reference step / CFL bound (h omega_max = 0.5)
  double duration = 0.0;  // work precision: simulated time of every scene (0: the scene's own)
  // s of stepping per stability cell: a cell that needs more is "too_slow" (for 0.1-0.15 s of a
  // 9 x 9 cloth, a real-time factor below 1/100).
  double cellBudget = 15.0;
  int grid = 9;               // vertices per side of the stability cases
  bool quiet = false;
};

std::vector<std::string> splitList(const std::vector<std::string>& items) {
  std::vector<std::string> out;
  for (const std::string& item : items) {
    std::stringstream s(item);
    for (std::string part; std::getline(s, part, ',');) {
      if (!part.empty()) out.push_back(part);
    }
  }
  return out;
}

bool selected(const std::vector<std::string>& filter, const std::string& name) {
  return filter.empty() || std::find(filter.begin(), filter.end(), name) != filter.end();
}

std::string csvText(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) {
    if (c == '"') q += '"';
    q += c == '\n' ? ' ' : c;
  }
  return q + "\"";
}

std::string num(double v, int precision = 6) {
  std::ostringstream s;
  s << std::setprecision(precision) << v;
  return s.str();
}

// "0.01", "1e-04" when short as a decimal, else "1/120".
std::string dtName(double dt) {
  if (std::abs(dt * 1e4 - std::round(dt * 1e4)) < 1e-9) return num(dt, 4);
  const double inverse = 1.0 / dt;
  if (std::abs(inverse - std::round(inverse)) < 1e-6 * inverse) {
    return "1/" + std::to_string(std::llround(inverse));
  }
  return num(dt, 4);
}

// A progress line on stderr: done / total weight (steps to simulate), ETA from the rate so far.
class Progress {
 public:
  Progress(std::string phase, double totalWeight, bool enabled)
      : phase_(std::move(phase)), total_(totalWeight), enabled_(enabled),
        tty_(isatty(STDERR_FILENO) != 0), start_(std::chrono::steady_clock::now()), last_(start_) {}
  void update(double doneWeight, int doneItems, int totalItems, const std::string& what) {
    if (!enabled_) return;
    const auto now = std::chrono::steady_clock::now();
    const bool finished = doneItems == totalItems;
    if (!finished && std::chrono::duration<double>(now - last_).count() < (tty_ ? 0.5 : 15.0)) return;
    last_ = now;
    const double wall = std::chrono::duration<double>(now - start_).count();
    const double f = total_ > 0.0 ? std::min(doneWeight / total_, 1.0) : 1.0;
    const double eta = f > 0.0 ? wall * (1.0 - f) / f : 0.0;
    std::fprintf(stderr, "%s%s: %d / %d (%3.0f%%), %.0f s, ETA %.0f s  %-48.48s%s", tty_ ? "\r" : "",
                 phase_.c_str(), doneItems, totalItems, 100.0 * f, wall, eta, what.c_str(),
                 tty_ ? "" : "\n");
    dirty_ = tty_;
  }
  ~Progress() {
    if (dirty_) std::fprintf(stderr, "\n");
  }

 private:
  std::string phase_;
  double total_;
  bool enabled_, tty_, dirty_ = false;
  std::chrono::steady_clock::time_point start_, last_;
};

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct WorkPrecisionRow {
  std::string scene, label, integrator;
  double dt = 0.0;
  std::string status, error;
  double wall = 0.0;
  int repeats = 0;
  RunResult run;
  PositionErrors errors;
};

// ------------------------------------------------------------------------------------------------
// Work precision
// ------------------------------------------------------------------------------------------------
// The study's CSV files, opened with their header lines.
struct WorkPrecisionFiles {
  std::ofstream wp, overTime, refs, orders, targets;

  explicit WorkPrecisionFiles(const std::string& out)
      : wp(out + "/work_precision.csv"), overTime(out + "/error_over_time.csv"),
        refs(out + "/references.csv"), orders(out + "/orders.csv"), targets(out + "/targets.csv") {
    wp << "scene,label,integrator,dt,status,wall_s,repeats,steps,substeps,newton_iterations,"
          "rollbacks,rms_end,max_end,rms_over_time,max_over_time,balance_end,balance_max_abs,"
          "energy_scale_j,max_stretch,max_stretch_reference,error\n";
    overTime << "scene,label,dt,t,rms,max\n";
    refs << "scene,description,dt,cfl_bound_s,omega_max,error_ratio,duration,samples,cloth_size_m,wall_s,cached,key,"
            "check_dt,check_rms_end,check_rms_over_time,check_max_over_time,max_stretch,balance_end\n";
    orders << "scene,label,integrator,points,order_rms_end,order_rms_over_time,order_finest,"
              "pairwise_rms_end\n";
    targets << "scene,target,label,integrator,dt,wall_s,rms_over_time\n";
  }
};

// The reference's step of a scene and the scene's CFL bound 2 / omega_max (s). The reference:
// BDF2 with a tight Newton tolerance and a step that resolves the fastest mode of the mesh (a
// quarter of the CFL bound, so h omega_max <= 0.5) and is at least 8x finer than the finest
// tested step; and the same at twice its step, whose difference from it bounds the reference's
// own error. Its steps per sample are a multiple of 2 q, q the command steps per sample, so that
// the reference and its check both sample at the same times and apply every recorded command at
// its stamp.
Expected<std::pair<double, double>> referenceStep(const Options& opt, const AccuracyScene& s) {
  std::vector<std::string> overrides = opt.overrides;
  overrides.push_back("integrator.name=bdf2");
  Expected<YAML::Node> probe = withOverrides(s.document, overrides);
  Expected<double> cfl = probe ? cflBound(*probe) : Expected<double>(Error{probe.error()});
  if (!cfl) return Error{cfl.error()};
  const double target = std::min(s.referenceDt, opt.referenceResolution * *cfl);
  const double q = s.commandGrid > 0.0 ? std::round(s.sampleInterval / s.commandGrid) : 1.0;
  const double perSample = 2.0 * q * std::ceil(s.sampleInterval / target / (2.0 * q) - 1e-9);
  return std::pair{s.sampleInterval / perSample, *cfl};
}

// A tested step must divide the scene's sample interval and divide or be a multiple of its
// command grid; the sample interval must divide the duration.
bool stepFitsScene(const AccuracyScene& s, double dt) {
  return wholeSteps(s.sampleInterval, dt) && wholeSteps(s.duration, s.sampleInterval) &&
         (!(s.commandGrid > 0.0) || ((wholeSteps(s.commandGrid, dt) || wholeSteps(dt, s.commandGrid)) &&
                                   wholeSteps(s.sampleInterval, s.commandGrid)));
}

// The settings a scene runs: every variant, or for a scene that wants the default settings the
// first variant of each integrator.
std::vector<const Variant*> sceneVariants(const AccuracyScene& s, const std::vector<Variant>& variants) {
  std::vector<const Variant*> out;
  std::set<std::string> seen;
  for (const Variant& variant : variants) {
    if (s.defaultSettingsOnly && !seen.insert(variant.integrator).second) continue;
    out.push_back(&variant);
  }
  return out;
}

// A run of the scene with the report's --set overrides, then `overrides`, for its duration.
Expected<RunRequest> runRequest(const Options& opt, const AccuracyScene& s,
                                const std::vector<std::string>& overrides) {
  std::vector<std::string> all = opt.overrides;
  all.insert(all.end(), overrides.begin(), overrides.end());
  all.push_back(setting("duration", s.duration));
  Expected<YAML::Node> doc = withOverrides(s.document, all);
  if (!doc) return Error{doc.error()};
  RunRequest r;
  r.scene = *doc;
  r.commands = s.recording;
  r.recordedDt = s.recording ? s.document["integrator"]["dt"].as<double>(0.01) : 0.0;
  r.duration = s.duration;
  r.sampleInterval = s.sampleInterval;
  return r;
}

// One setting at one step: its first run, and the median wall time of up to --repeats runs (no
// more once they took --repeat-budget).
WorkPrecisionRow runSetting(const Options& opt, const AccuracyScene& s, const Variant& variant, double dt,
                            bool& nonFinite) {
  WorkPrecisionRow row;
  row.scene = s.name;
  row.label = variant.label;
  row.integrator = variant.integrator;
  row.dt = dt;
  std::vector<std::string> overrides = variant.overrides;
  overrides.push_back(setting("integrator.dt", dt));
  Expected<RunRequest> req = runRequest(opt, s, overrides);
  if (!req) {
    row.status = "n/a";
    row.error = req.error();
    return row;
  }
  std::vector<double> walls;
  double spent = 0.0;
  do {
    RunResult r = runScene(*req);
    walls.push_back(r.wall);
    spent += r.wall;
    if (walls.size() == 1) row.run = std::move(r);
  } while (row.run.outcome == RunResult::Outcome::Completed &&
           static_cast<int>(walls.size()) < opt.repeats && spent < opt.repeatBudget);
  row.wall = median(walls);
  row.repeats = static_cast<int>(walls.size());
  row.error = row.run.error;
  switch (row.run.outcome) {
    case RunResult::Outcome::Completed: row.status = "ok"; break;
    // The reference built, so the scene is sound: the integrator refuses it.
    case RunResult::Outcome::BuildError: row.status = "n/a"; break;
    default: row.status = outcomeName(row.run.outcome);
  }
  if (row.run.outcome == RunResult::Outcome::NonFinite) nonFinite = true;
  return row;
}

// The study: every chosen scene's reference and its check, then every setting at every step,
// then the convergence orders and the cheapest runs reaching each error target.
class WorkPrecisionStudy {
 public:
  WorkPrecisionStudy(const Options& opt, std::vector<AccuracyScene> scenes, std::vector<Variant> variants)
      : opt_(opt), scenes_(std::move(scenes)), variants_(std::move(variants)), files_(opt.out),
        cache_(opt.cache.empty() ? opt.out + "/cache" : opt.cache) {}

  // The exit status of the report (0, 2 or 3); a non-finite run sets nonFinite.
  int run(std::ostream& summary, bool& nonFinite) {
    if (int status = plan(); status != 0) return status;
    progress_ = std::make_unique<Progress>("work precision", totalWeight_, !opt_.quiet);
    for (const AccuracyScene& s : scenes_) {
      std::optional<Reference> reference;
      if (int status = runReferences(s, reference); status != 0) return status;
      for (const Variant* variant : sceneVariants(s, variants_)) {
        for (double dt : s.dts) {
          report(s.name + " " + variant->label + " dt " + dtName(dt));
          WorkPrecisionRow row = runSetting(opt_, s, *variant, dt, nonFinite);
          const RunResult& R = reference->run;
          row.errors = positionErrors(row.run.samples, R.samples, R.dim, R.clothSize);
          writeRow(row, R);
          rows_.push_back(std::move(row));
          done(s.duration / dt);
        }
      }
      report(s.name + " done");
    }
    summariseOrders(summary);
    summariseTargets(summary);
    summary << '\n';
    return 0;
  }

 private:
  // The reference steps, the steps' check and the total weight (steps to simulate) for the
  // progress line.
  int plan() {
    for (const AccuracyScene& s : scenes_) {
      Expected<std::pair<double, double>> step = referenceStep(opt_, s);
      if (!step) {
        std::cerr << "fem_cloth_report: " << s.name << ": " << step.error() << '\n';
        return 2;
      }
      referenceSteps_[s.name] = *step;
    }
    for (const AccuracyScene& s : scenes_) {
      for (double dt : s.dts) {
        if (!stepFitsScene(s, dt)) {
          std::cerr << "fem_cloth_report: scene " << s.name << ": dt = " << dt << " s must divide the "
                    << "sample interval " << s.sampleInterval << " s and divide or be a multiple of its "
                    << "command grid; the sample interval must divide the duration\n";
          return 2;
        }
      }
      // The reference and its check at twice its step.
      totalWeight_ += 1.5 * s.duration / referenceSteps_[s.name].first;
      totalItems_ += 2;
      for (std::size_t k = 0; k < sceneVariants(s, variants_).size(); ++k) {
        for (double dt : s.dts) {
          totalWeight_ += s.duration / dt;
          ++totalItems_;
        }
      }
    }
    return 0;
  }

  // The reference of a scene and its check at twice the step: references.csv, and the check's
  // error over time in error_over_time.csv.
  int runReferences(const AccuracyScene& s, std::optional<Reference>& reference) {
    const auto [referenceDt, cfl] = referenceSteps_.at(s.name);
    std::vector<double> checkErrors;
    for (const double refDt : {referenceDt, 2.0 * referenceDt}) {
      report(s.name + " reference dt " + num(refDt, 3));
      Expected<RunRequest> req = runRequest(opt_, s, {"integrator.name=bdf2", setting("integrator.dt", refDt),
                                                      setting("integrator.error_ratio", s.referenceErrorRatio),
                                                      setting("integrator.error_cap", s.referenceErrorRatio),
                                                      "integrator.error_floor=1e-9"});
      if (!req) {
        std::cerr << "fem_cloth_report: " << s.name << ": " << req.error() << '\n';
        return 2;
      }
      Expected<Reference> ref = cachedReference(*req, s.commandsBag, cache_);
      if (!ref) {
        std::cerr << "fem_cloth_report: " << s.name << ": " << ref.error() << '\n';
        return 3;
      }
      done(s.duration / refDt);
      if (!reference) {
        reference = std::move(ref).value();
        continue;
      }
      const PositionErrors check = positionErrors(ref->run.samples, reference->run.samples,
                                                  reference->run.dim, reference->run.clothSize);
      checkErrors = {check.rmsEnd, check.rmsOverTime, check.maxOverTime};
      for (std::size_t k = 0; k < check.rms.size(); ++k) {
        files_.overTime << s.name << ",reference check," << num(2.0 * referenceDt, 17) << ','
                        << num(reference->run.sampleTimes[k], 10) << ',' << num(check.rms[k]) << ','
                        << num(check.max[k]) << '\n';
      }
    }
    const RunResult& R = reference->run;
    files_.refs << s.name << ',' << csvText(s.description) << ',' << num(referenceDt, 17) << ','
                << num(cfl) << ',' << num(2.0 / cfl) << ',' << s.referenceErrorRatio << ',' << s.duration << ','
                << R.samples.size() << ',' << num(R.clothSize) << ',' << num(R.wall) << ','
                << (reference->cached ? 1 : 0) << ',' << reference->key << ',' << num(2 * referenceDt, 17) << ','
                << num(checkErrors[0]) << ',' << num(checkErrors[1]) << ',' << num(checkErrors[2]) << ','
                << num(R.maxStretch) << ',' << num(R.balanceEnd) << '\n';
    files_.refs.flush();
    return 0;
  }

  // A setting's row of work_precision.csv and its error over time, against the reference R.
  void writeRow(const WorkPrecisionRow& row, const RunResult& R) {
    const double scale = row.run.weightScale > 0.0 ? row.run.weightScale : R.weightScale;
    files_.wp << row.scene << ',' << csvText(row.label) << ',' << row.integrator << ',' << num(row.dt, 17)
              << ',' << row.status << ',' << num(row.wall) << ',' << row.repeats << ','
              << row.run.steps << ',' << row.run.substeps << ',' << row.run.newtonIterations << ','
              << row.run.rollbacks << ',' << num(row.errors.rmsEnd) << ',' << num(row.errors.maxEnd)
              << ',' << num(row.errors.rmsOverTime) << ',' << num(row.errors.maxOverTime) << ','
              << num(row.run.balanceEnd / scale) << ',' << num(row.run.balanceMaxAbs / scale) << ','
              << num(scale) << ',' << num(row.run.maxStretch) << ',' << num(R.maxStretch) << ','
              << csvText(row.error) << '\n';
    files_.wp.flush();
    for (std::size_t k = 0; k < row.errors.rms.size(); ++k) {
      files_.overTime << row.scene << ',' << csvText(row.label) << ',' << num(row.dt, 17) << ','
                      << num(R.sampleTimes[k], 10) << ',' << num(row.errors.rms[k]) << ','
                      << num(row.errors.max[k]) << '\n';
    }
  }

  // Orders: slope of log error against log dt, over all completed runs of a setting, and over
  // its three finest steps (closest to the asymptotic range).
  void summariseOrders(std::ostream& summary) {
    summary << "== Convergence orders (slope of log error against log dt; RMS position error)\n";
    summary << std::left << std::setw(14) << "scene" << std::setw(26) << "setting" << std::setw(10)
            << "at end" << std::setw(12) << "over time" << std::setw(14) << "finest 3"
            << "pairwise (coarse to fine)\n";
    for (const AccuracyScene& s : scenes_) {
      for (const Variant& variant : variants_) {
        std::vector<double> dts, end, overall;
        for (const WorkPrecisionRow& r : rows_) {
          if (r.scene != s.name || r.label != variant.label || r.status != "ok") continue;
          dts.push_back(r.dt);
          end.push_back(r.errors.rmsEnd);
          overall.push_back(r.errors.rmsOverTime);
        }
        if (dts.empty()) continue;
        const double pEnd = fittedOrder(dts, end), pTime = fittedOrder(dts, overall);
        const std::size_t k = dts.size() >= 3 ? dts.size() - 3 : 0;
        const double pFine = fittedOrder(std::vector<double>(dts.begin() + k, dts.end()),
                                         std::vector<double>(end.begin() + k, end.end()));
        std::string pairwise;
        for (std::size_t i = 1; i < dts.size(); ++i) {
          pairwise += (i > 1 ? " " : "") + num(std::log(end[i - 1] / end[i]) / std::log(dts[i - 1] / dts[i]), 3);
        }
        files_.orders << s.name << ',' << csvText(variant.label) << ',' << variant.integrator << ','
                      << dts.size() << ',' << num(pEnd, 4) << ',' << num(pTime, 4) << ',' << num(pFine, 4)
                      << ',' << pairwise << '\n';
        summary << std::left << std::setw(14) << s.name << std::setw(26) << variant.label
                << std::setw(10) << num(pEnd, 3) << std::setw(12) << num(pTime, 3) << std::setw(14)
                << num(pFine, 3) << pairwise << '\n';
      }
    }
  }

  // The ranking: for each error target, the cheapest run of each setting that reaches it.
  void summariseTargets(std::ostream& summary) {
    summary << "\n== Cheapest run reaching an RMS error over time (relative to the cloth size)\n";
    for (const AccuracyScene& s : scenes_) {
      for (double target : {1e-1, 1e-2, 1e-3}) {
        const std::vector<const WorkPrecisionRow*> best = cheapestReaching(s, target);
        summary << s.name << ", error <= " << num(target) << ": ";
        if (best.empty()) summary << "no run";
        for (std::size_t i = 0; i < best.size(); ++i) {
          const WorkPrecisionRow& r = *best[i];
          files_.targets << s.name << ',' << num(target) << ',' << csvText(r.label) << ',' << r.integrator
                         << ',' << num(r.dt, 17) << ',' << num(r.wall) << ',' << num(r.errors.rmsOverTime) << '\n';
          if (i < 4) summary << (i ? "; " : "") << r.label << " dt " << dtName(r.dt) << " " << num(r.wall, 3) << " s";
        }
        summary << '\n';
      }
    }
  }

  // The cheapest completed run of each setting of a scene within the target error, cheapest first.
  std::vector<const WorkPrecisionRow*> cheapestReaching(const AccuracyScene& s, double target) const {
    std::vector<const WorkPrecisionRow*> best;
    for (const Variant& variant : variants_) {
      const WorkPrecisionRow* cheapest = nullptr;
      for (const WorkPrecisionRow& r : rows_) {
        if (r.scene != s.name || r.label != variant.label || r.status != "ok") continue;
        if (!(r.errors.rmsOverTime <= target)) continue;
        if (cheapest == nullptr || r.wall < cheapest->wall) cheapest = &r;
      }
      if (cheapest) best.push_back(cheapest);
    }
    std::sort(best.begin(), best.end(), [](auto* a, auto* b) { return a->wall < b->wall; });
    return best;
  }

  void report(const std::string& what) { progress_->update(doneWeight_, doneItems_, totalItems_, what); }
  void done(double weight) {
    doneWeight_ += weight;
    ++doneItems_;
  }

  const Options& opt_;
  const std::vector<AccuracyScene> scenes_;
  const std::vector<Variant> variants_;
  WorkPrecisionFiles files_;
  const std::string cache_;
  std::map<std::string, std::pair<double, double>> referenceSteps_;  // scene: (dt, CFL bound)
  std::unique_ptr<Progress> progress_;
  double totalWeight_ = 0.0, doneWeight_ = 0.0;
  int totalItems_ = 0, doneItems_ = 0;
  std::vector<WorkPrecisionRow> rows_;
};

// The integrators the work-precision study runs (--integrators), in the registry's order.
std::vector<std::string> studyIntegrators(const Options& opt) {
  std::vector<std::string> integrators;
  for (const std::string& name : integratorNames()) {
    if (selected(opt.integrators, name)) integrators.push_back(name);
  }
  return integrators;
}

int workPrecision(const Options& opt, std::ostream& summary, bool& nonFinite) {
  if (!opt.recordingError.empty()) {
    std::cerr << "fem_cloth_report: " << opt.recordingError << '\n';
    return 2;
  }
  Expected<std::vector<AccuracyScene>> scenes = accuracyScenes(opt.configDir, opt.recording, opt.small);
  if (!scenes) {
    std::cerr << "fem_cloth_report: " << scenes.error() << '\n';
    return 2;
  }
  const std::vector<std::string> integrators = studyIntegrators(opt);
  std::vector<AccuracyScene> chosen;
  for (AccuracyScene& s : *scenes) {
    if (opt.duration > 0.0) s.duration = opt.duration;
    if (selected(opt.scenes, s.name)) chosen.push_back(s);
  }
  WorkPrecisionStudy study(opt, std::move(chosen), workPrecisionVariants(integrators, opt.small));
  return study.run(summary, nonFinite);
}

// ------------------------------------------------------------------------------------------------
// Stability matrix
// ------------------------------------------------------------------------------------------------
struct CellRun {
  Cell cell;
  Stiffness level;
  double duration = 0.0;
  CellResult result;
};

// The cells of the selection, in the order of stability.csv (the runner's tasks name them by
// their index in it).
struct StabilityPlan {
  std::vector<std::string> cases, materials, integrators;
  std::vector<Stiffness> levels;
  std::vector<double> dts;
  std::vector<CellRun> cells;
  double totalWeight = 0.0;  // steps to simulate
};

int planStability(const Options& opt, StabilityPlan& plan) {
  for (const std::string& c : extremeCaseNames()) {
    if (selected(opt.cases, c)) plan.cases.push_back(c);
  }
  for (const std::string& m : materialNames()) {
    if (selected(opt.materials, m)) plan.materials.push_back(m);
  }
  for (const std::string& i : integratorNames()) {
    if (selected(opt.integrators, i)) plan.integrators.push_back(i);
  }
  for (const Stiffness& l : stiffnessLevels()) {
    if (selected(opt.stiffness, l.name)) plan.levels.push_back(l);
  }
  for (double dt : stabilityDts()) {
    if (opt.dts.empty() || std::any_of(opt.dts.begin(), opt.dts.end(),
                                       [&](double d) { return std::abs(d - dt) <= 1e-9 * dt; })) {
      plan.dts.push_back(dt);
    }
  }
  if (opt.small) {
    // The smoke test: three cases, two materials, cotton, the two largest steps.
    if (opt.cases.empty()) plan.cases = {"pull_corner", "squash", "strip"};
    if (opt.materials.empty()) plan.materials = {"stvk", "neo_hookean"};
    if (opt.stiffness.empty()) plan.levels = {plan.levels.front()};
    if (opt.dts.empty()) plan.dts = {1e-2, 1.0 / 30.0};
  }
  for (const std::string& c : plan.cases) {
    Expected<YAML::Node> base = extremeCase(c, opt.grid);
    if (!base) {
      std::cerr << "fem_cloth_report: " << base.error() << '\n';
      return 2;
    }
    const double duration = (*base)["duration"].as<double>();
    for (double dt : plan.dts) {
      if (!wholeSteps(duration, dt)) {
        std::cerr << "fem_cloth_report: case " << c << ": dt = " << dt << " s does not divide its "
                  << "duration " << duration << " s\n";
        return 2;
      }
    }
    for (const std::string& material : plan.materials) {
      for (const Stiffness& level : plan.levels) {
        // The strip is the strip, cotton-like (cases.h).
        if (c == "strip" && level.name != stiffnessLevels().front().name) continue;
        for (const std::string& integrator : plan.integrators) {
          for (double dt : plan.dts) {
            CellRun cell;
            cell.cell = Cell{c, material, level.name, integrator, dt};
            cell.level = level;
            cell.duration = duration;
            plan.cells.push_back(cell);
            plan.totalWeight += duration / dt;
          }
        }
      }
    }
  }
  return 0;
}

std::string cellName(const Cell& c) {
  return c.caseName + " " + c.material + " " + c.stiffness + " " + c.integrator + " dt " + dtName(c.dt);
}

// Runs cells [first, last) one after the other. In parallel they go through fem_cloth_batch's
// runner on Dask (scripts/report), one task per slice of cells (--cells, --cell-results); their
// wall times are only reported (a stability cell is not a timing measurement).
void runCells(const Options& opt, std::vector<CellRun>& cells, std::size_t first, std::size_t last) {
  double totalWeight = 0.0, doneWeight = 0.0;
  for (std::size_t i = first; i < last; ++i) totalWeight += cells[i].duration / cells[i].cell.dt;
  Progress progress("stability", totalWeight, !opt.quiet);
  for (std::size_t i = first; i < last; ++i) {
    CellRun& c = cells[i];
    c.result = runCell(c.cell, opt.grid, opt.cellBudget);
    doneWeight += c.duration / c.cell.dt;
    progress.update(doneWeight, static_cast<int>(i + 1 - first), static_cast<int>(last - first),
                    cellName(c.cell));
  }
}

// The cell's row of stability.csv (after the header stabilityHeader()).
const char* stabilityHeader() {
  return "case,material,stiffness,youngs_modulus,poisson_ratio,integrator,dt,verdict,steps,"
         "total_steps,t_reached,rollbacks,max_substeps,substeps,newton_iterations,energy_growth,"
         "min_j,min_j_end,max_stretch,wall_s,error";
}

std::string stabilityRow(const CellRun& c) {
  const RunResult& r = c.result.run;
  const std::uint64_t totalSteps = static_cast<std::uint64_t>(std::llround(c.duration / c.cell.dt));
  std::ostringstream row;
  row << c.cell.caseName << ',' << c.cell.material << ',' << c.level.name << ','
      << num(c.level.youngsModulus) << ',' << c.level.poissonRatio << ',' << c.cell.integrator
      << ',' << num(c.cell.dt, 17) << ',' << c.result.verdict << ',' << r.steps << ',' << totalSteps
      << ',' << num(r.simulated) << ',' << r.rollbacks << ',' << r.maxSubsteps << ','
      << r.substeps << ',' << r.newtonIterations << ',' << num(r.energyGrowth) << ','
      << (std::isfinite(r.minJ) ? num(r.minJ) : "") << ','
      << (std::isfinite(r.minJEnd) ? num(r.minJEnd) : "") << ',' << num(r.maxStretch) << ','
      << num(r.wall) << ',' << csvText(r.error);
  return row.str();
}

// ------------------------------------------------------------------------------------------------
// Cells as runner tasks: the cell list, and each slice's results — per cell its verdict and its
// row of stability.csv, as this program wrote them — read back in the end.
// ------------------------------------------------------------------------------------------------
using Json = nlohmann::ordered_json;

Json cellIdentity(const CellRun& c, std::size_t index) {
  return Json{{"index", index},          {"case", c.cell.caseName}, {"material", c.cell.material},
              {"stiffness", c.cell.stiffness}, {"integrator", c.cell.integrator},
              {"dt", c.cell.dt},          {"weight", c.duration / c.cell.dt}};
}

bool sameCell(const Json& j, const CellRun& c) {
  return j.at("case") == c.cell.caseName && j.at("material") == c.cell.material &&
         j.at("stiffness") == c.cell.stiffness && j.at("integrator") == c.cell.integrator &&
         j.at("dt").get<double>() == c.cell.dt;
}

bool writeJson(const std::string& path, const Json& j) {
  std::ofstream(path + ".partial") << j.dump(1) << '\n';
  std::error_code ec;
  std::filesystem::rename(path + ".partial", path, ec);
  if (ec) std::cerr << "fem_cloth_report: cannot write '" << path << "': " << ec.message() << '\n';
  return !ec;
}

// Every cell of the plan from the *.json files of a folder (each {"cells": [...]}, as --cells
// writes them): each cell exactly once, the same cell as the plan has at that index.
int readCellResults(const std::string& folder, StabilityPlan& plan, std::vector<std::string>& rows) {
  rows.assign(plan.cells.size(), "");
  std::vector<bool> seen(plan.cells.size(), false);
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(folder, ec)) {
    if (entry.path().extension() != ".json") continue;
    try {
      const Json file = Json::parse(std::ifstream(entry.path()));
      for (const Json& j : file.at("cells")) {
        const std::size_t i = j.at("index").get<std::size_t>();
        if (i >= plan.cells.size() || !sameCell(j, plan.cells[i])) {
          std::cerr << "fem_cloth_report: " << entry.path().string() << ": cell " << i
                    << " is not a cell of this selection (another --cases, --materials, ... ?)\n";
          return 2;
        }
        if (seen[i]) {
          std::cerr << "fem_cloth_report: " << folder << ": cell " << i << " (" << cellName(plan.cells[i].cell)
                    << ") has two results\n";
          return 2;
        }
        plan.cells[i].result.verdict = j.at("verdict").get<std::string>();
        rows[i] = j.at("row").get<std::string>();
        seen[i] = true;
      }
    } catch (const Json::exception& e) {
      std::cerr << "fem_cloth_report: " << entry.path().string() << ": not a cell result file (" << e.what() << ")\n";
      return 2;
    }
  }
  if (ec) {
    std::cerr << "fem_cloth_report: cannot read the cell results in '" << folder << "': " << ec.message() << '\n';
    return 2;
  }
  for (std::size_t i = 0; i < seen.size(); ++i) {
    if (!seen[i]) {
      std::cerr << "fem_cloth_report: " << folder << ": no result for cell " << i << " ("
                << cellName(plan.cells[i].cell) << ")\n";
      return 2;
    }
  }
  return 0;
}

// stability.csv from the rows, and the summary's verdict counts.
void writeStability(const Options& opt, const StabilityPlan& plan, const std::vector<std::string>& rows,
                    std::ostream& summary, bool& nonFinite) {
  std::ofstream csv(opt.out + "/stability.csv");
  csv << stabilityHeader() << '\n';
  for (const std::string& row : rows) csv << row << '\n';
  std::map<std::string, int> counts;
  std::map<std::string, std::map<std::string, int>> perIntegrator;
  for (const CellRun& c : plan.cells) {
    const std::string& verdict = c.result.verdict;
    if (verdict == "non_finite") nonFinite = true;
    ++counts[verdict];
    ++perIntegrator[c.cell.integrator][verdict];
  }

  const std::vector<std::string>& verdicts = verdictNames();
  summary << "== Stability matrix: " << plan.cells.size() << " cells (" << plan.cases.size() << " cases x "
          << plan.materials.size() << " materials x " << plan.levels.size() << " stiffnesses x "
          << plan.integrators.size() << " integrators x " << plan.dts.size() << " steps)\n";
  summary << std::left << std::setw(20) << "";
  for (const std::string& v : verdicts) summary << std::setw(13) << v;
  summary << '\n' << std::setw(20) << "all";
  for (const std::string& v : verdicts) summary << std::setw(13) << counts[v];
  summary << '\n';
  for (const std::string& i : plan.integrators) {
    summary << std::setw(20) << i;
    for (const std::string& v : verdicts) summary << std::setw(13) << perIntegrator[i][v];
    summary << '\n';
  }
  summary << '\n';
}

// --list-cells and --cells: a runner's side of the stability matrix; otherwise every cell, run
// here or read back from --from-cell-results, into stability.csv and the summary.
int stability(const Options& opt, std::ostream& summary, bool& nonFinite) {
  StabilityPlan plan;
  if (int status = planStability(opt, plan); status != 0) return status;
  if (!opt.listCells.empty()) {
    Json list = Json::array();
    for (std::size_t i = 0; i < plan.cells.size(); ++i) list.push_back(cellIdentity(plan.cells[i], i));
    return writeJson(opt.listCells, Json{{"cells", list}}) ? 0 : 2;
  }
  if (!opt.cellRange.empty()) {
    std::size_t first = 0, last = 0;
    char colon = 0;
    std::istringstream range(opt.cellRange);
    if (!(range >> first >> colon >> last) || colon != ':' || !range.eof() || first >= last ||
        last > plan.cells.size()) {
      std::cerr << "fem_cloth_report: --cells must be FIRST:LAST with 0 <= FIRST < LAST <= "
                << plan.cells.size() << " (the cells of this selection), got '" << opt.cellRange << "'\n";
      return 2;
    }
    runCells(opt, plan.cells, first, last);
    Json results = Json::array();
    for (std::size_t i = first; i < last; ++i) {
      if (plan.cells[i].result.verdict == "non_finite") nonFinite = true;
      Json j = cellIdentity(plan.cells[i], i);
      j["verdict"] = plan.cells[i].result.verdict;
      j["row"] = stabilityRow(plan.cells[i]);
      results.push_back(std::move(j));
    }
    return writeJson(opt.cellResults, Json{{"cells", results}}) ? 0 : 2;
  }
  std::vector<std::string> rows;
  if (!opt.fromCellResults.empty()) {
    if (int status = readCellResults(opt.fromCellResults, plan, rows); status != 0) return status;
  } else {
    runCells(opt, plan.cells, 0, plan.cells.size());
    for (const CellRun& c : plan.cells) rows.push_back(stabilityRow(c));
  }
  writeStability(opt, plan, rows, summary, nonFinite);
  return 0;
}

// What is wrong with --set for the work-precision study, or "". The overrides are applied as
// fem_cloth_sim applies --set (applySceneOverrides: the key must exist, and an integrator key must
// be read by the integrator), once for every integrator of the study: a key one of them does not
// read is refused with fem_cloth_sim's message, naming that integrator. And a key the study sets
// itself in a run, after --set (its variant's keys: integrator.name and the setting swept;
// integrator.dt; duration), would be ignored there: refused, naming the run.
std::string checkOverrides(const Options& opt) {
  if (opt.overrides.empty() || opt.study == "stability") return "";
  const std::vector<std::string> integrators = studyIntegrators(opt);
  for (const std::string& name : integrators) {
    YAML::Node document(YAML::NodeType::Map);
    std::vector<std::string> overrides = opt.overrides;
    overrides.push_back("integrator.name=" + name);
    if (Status s = applySceneOverrides(document, overrides); !s) return s.error();
  }
  auto key = [](const std::string& o) { return o.substr(0, o.find('=')); };
  for (const Variant& v : workPrecisionVariants(integrators, opt.small)) {
    std::vector<std::string> own = v.overrides;
    own.insert(own.end(), {"integrator.dt=", "duration="});
    for (const std::string& o : opt.overrides) {
      for (const std::string& k : own) {
        if (key(o) != key(k)) continue;
        return "--set " + key(o) + ": the study sets it itself in its run '" + v.label + "' (integrator.name, "
               "integrator.dt and duration in every run: choose them with --integrators and --duration), "
               "so the value given would be ignored";
      }
    }
  }
  return "";
}

// What is wrong with the options' values (one line naming the option), or "": checked before any
// work, so that a value that cannot work is not refused only after the studies before it ran.
std::string checkOptionValues(const CLI::App& app, const Options& opt) {
  const auto positive = [](double x) { return x > 0.0 && std::isfinite(x); };
  if (!positive(opt.referenceResolution)) {
    return "--reference-resolution must be positive and finite (a fraction of the CFL bound), got " + num(opt.referenceResolution);
  }
  if (app.count("--duration") != 0 && !positive(opt.duration)) {
    return "--duration must be positive and finite (s), got " + num(opt.duration);
  }
  if (!positive(opt.cellBudget)) return "--cell-budget must be positive and finite (s), got " + num(opt.cellBudget);
  std::string steps;
  for (double dt : stabilityDts()) steps += (steps.empty() ? "" : ", ") + num(dt);
  for (double d : opt.dts) {
    const bool known = std::any_of(stabilityDts().begin(), stabilityDts().end(),
                                   [&](double dt) { return std::abs(d - dt) <= 1e-9 * dt; });
    if (!known) return "--dts: " + num(d) + " s is not a step of the stability matrix (" + steps + ")";
  }
  if (Expected<YAML::Node> doc = extremeCase(extremeCaseNames().front(), opt.grid); !doc) {
    return "--grid: " + doc.error();
  }
  std::vector<std::string> levels;
  for (const Stiffness& l : stiffnessLevels()) levels.push_back(l.name);
  for (const auto& [option, given, known] :
       {std::tuple{"--cases", &opt.cases, extremeCaseNames()}, std::tuple{"--materials", &opt.materials, materialNames()},
        std::tuple{"--stiffness", &opt.stiffness, levels}}) {
    for (const std::string& name : *given) {
      if (!selected(known, name)) {
        std::string list;
        for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
        return std::string(option) + ": unknown name '" + name + "' (" + list + ")";
      }
    }
  }
  if (std::error_code ec; !opt.fromCellResults.empty() && !std::filesystem::is_directory(opt.fromCellResults, ec)) {
    return "--from-cell-results: there is no folder '" + opt.fromCellResults + "'";
  }
  if (const std::string problem = checkOverrides(opt); !problem.empty()) return problem;
  // The runner's outputs, before its cells run (a slice of cells takes minutes).
  for (const auto& [option, path] : {std::pair{"--list-cells", &opt.listCells}, std::pair{"--cell-results", &opt.cellResults}}) {
    if (Status s = path->empty() ? Status::success() : checkOutputPath(*path); !s) return std::string(option) + ": " + s.error();
  }
  return "";
}

// The command line into `opt`, with the package's defaults for --config and --bag and the lists
// split at commas; an exit status when the program ends here (--help, a bad command line).
std::optional<int> parseCommandLine(int argc, char** argv, Options& opt) {
  CLI::App app{
      "The fem_cloth accuracy and stability report (docs/accuracy.md): work precision and\n"
      "convergence orders of every integrator on the standard scenes, and the stability matrix\n"
      "on extreme cases. Writes CSV files and summary.txt to --out; scripts/report plots them."};
  app.add_option("--out", opt.out, "output folder (default output/report)");
  app.add_option("--cache", opt.cache, "reference cache folder (default <out>/cache)");
  app.add_option("--config", opt.configDir, "folder of the standard scenes");
  app.add_option("--bag", opt.bag, "the recorded grasp-and-lift whose commands drive the grasp scene ('' to skip)");
  app.add_flag("--small", opt.small, "the small version (smoke test): small meshes, few runs and cells");
  app.add_option("--study", opt.study, "all, work-precision or stability")
      ->check(CLI::IsMember({"all", "work-precision", "stability"}));
  app.add_option("--integrators", opt.integrators, "only these integrators (comma-separated)");
  app.add_option("--scenes", opt.scenes, "only these work-precision scenes");
  app.add_option("--cases", opt.cases, "only these stability cases");
  app.add_option("--materials", opt.materials, "only these materials (stability)");
  app.add_option("--stiffness", opt.stiffness, "only these stiffness levels (stability): cotton, 100x, 1000x");
  app.add_option("--dts", opt.dts, "only these steps (stability; s)");
  app.add_option("--reference-resolution", opt.referenceResolution,
                 "reference step as a fraction of the scene's CFL bound 2/omega_max (default 0.25)");
  app.add_option("--duration", opt.duration, "work precision: simulated time (s) of every scene");
  app.add_option("--set", opt.overrides, "work precision: key.path=value on every scene (repeatable); an "
                 "integrator.KEY must be read by every integrator of the study (--integrators), as "
                 "fem_cloth_sim --set checks, and not be one the study sets in its runs (integrator.name, "
                 "integrator.dt, duration, the setting it sweeps)");
  app.add_option("--list-cells", opt.listCells,
                 "stability: write the selection's cells (index, case, material, stiffness, "
                 "integrator, dt, weight) to this JSON file and stop");
  app.add_option("--cells", opt.cellRange, "stability: run only cells FIRST:LAST of the selection "
                 "(a runner task; with --cell-results)");
  app.add_option("--cell-results", opt.cellResults, "with --cells: write their results to this JSON file");
  app.add_option("--from-cell-results", opt.fromCellResults,
                 "stability: read every cell's result from the JSON files in this folder (what "
                 "--cells wrote) instead of running them");
  app.add_option("--repeats", opt.repeats, "timing repeats per run (median; fewer once a setting took 2 s)")
      ->check(fem_cloth::positiveNumber());
  app.add_option("--cell-budget", opt.cellBudget, "wall time (s) after which a stability cell stops");
  app.add_option("--grid", opt.grid, "vertices per side of the stability cases (odd, >= 5)");
  app.add_flag("--quiet,-q", opt.quiet, "no progress display");
  if (const std::optional<int> status = fem_cloth::parseToolCommandLine(app, argc, argv, "fem_cloth_report")) {
    return status;
  }
  // The defaults from the installed package (or the devel space's source tree): no path of the
  // source tree is compiled in (core/package_paths.h).
  for (const auto& [name, value, relative] :
       {std::tuple{"--config", &opt.configDir, "config"},
        std::tuple{"--bag", &opt.bag, "test/data/small_grasp.bag"}}) {
    if (app.count(name) != 0) continue;
    const Expected<std::filesystem::path> found = findPackageFile(relative);
    if (!found) {
      std::cerr << "fem_cloth_report: " << found.error() << " (give " << name << ")\n";
      return 2;
    }
    *value = found->string();
  }
  opt.integrators = splitList(opt.integrators);
  opt.scenes = splitList(opt.scenes);
  opt.cases = splitList(opt.cases);
  opt.materials = splitList(opt.materials);
  opt.stiffness = splitList(opt.stiffness);
  for (const std::string& name : opt.integrators) {
    if (!selected(integratorNames(), name)) {
      std::cerr << "fem_cloth_report: --integrators: unknown integrator '" << name << "'\n";
      return 2;
    }
  }
  if (const std::string problem = checkOptionValues(app, opt); !problem.empty()) {
    std::cerr << "fem_cloth_report: " << problem << '\n';
    return 2;
  }
  return std::nullopt;
}

// A runner's task (scripts/report, fem_cloth_batch report): cells only, no report files.
int runCellTask(const Options& opt) {
  if (opt.study != "stability" || !opt.fromCellResults.empty() ||
      (!opt.listCells.empty() && !opt.cellRange.empty()) || opt.cellRange.empty() != opt.cellResults.empty()) {
    std::cerr << "fem_cloth_report: --list-cells FILE, or --cells FIRST:LAST with --cell-results FILE, "
                 "go with --study stability alone\n";
    return 2;
  }
  std::ostringstream unused;
  bool nonFinite = false;
  const int status = stability(opt, unused, nonFinite);
  return status != 0 ? status : (nonFinite ? 4 : 0);
}

// The output folder, and in it every scene of the report as a file, so that any run or cell can
// be repeated by hand:
//   fem_cloth_sim --scene <out>/scenes/pull_corner.yaml --set material.model=arap --dt 0.01
int writeSceneFiles(const Options& opt) {
  std::error_code ec;
  std::filesystem::create_directories(opt.out, ec);
  if (ec) {
    std::cerr << "fem_cloth_report: cannot create '" << opt.out << "': " << ec.message() << '\n';
    return 2;
  }
  std::filesystem::create_directories(opt.out + "/scenes", ec);
  for (const std::string& c : extremeCaseNames()) {
    if (Expected<YAML::Node> doc = extremeCase(c, opt.grid)) {
      std::ofstream(opt.out + "/scenes/" + c + ".yaml")
          << "# stability case: " << extremeCaseDescription(c) << "\n" << sceneDocumentToString(*doc) << '\n';
    }
  }
  if (opt.study != "stability") {
    if (Expected<std::vector<AccuracyScene>> scenes = accuracyScenes(opt.configDir, opt.recording, opt.small)) {
      for (const AccuracyScene& s : *scenes) {
        std::ofstream(opt.out + "/scenes/" + s.name + ".yaml")
            << "# work-precision scene: " << s.description << "\n" << sceneDocumentToString(s.document) << '\n';
      }
    }
  }
  return 0;
}

// The studies --study asks for, into summary.txt (also printed).
int runStudies(const Options& opt) {
  const auto start = std::chrono::steady_clock::now();
  std::ostringstream summary;
  bool nonFinite = false;
  if (opt.study != "stability") {
    if (int status = workPrecision(opt, summary, nonFinite); status != 0) return status;
  }
  if (opt.study != "work-precision") {
    if (int status = stability(opt, summary, nonFinite); status != 0) return status;
  }
  summary << "report: " << num(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 4)
          << " s, outputs in " << opt.out << '\n';
  std::ofstream(opt.out + "/summary.txt") << summary.str();
  std::cout << summary.str();
  if (nonFinite) {
    std::cerr << "fem_cloth_report: a run or cell was non-finite (see the CSV files): a bug\n";
    return 4;
  }
  return 0;
}

int runReport(int argc, char** argv) {
  Options opt;
  if (const std::optional<int> status = parseCommandLine(argc, argv, opt)) return *status;
  if (!opt.listCells.empty() || !opt.cellRange.empty()) return runCellTask(opt);
  // The recorded grasp, read by the ROS side's bag reader (the report library knows no bags).
  if (!opt.bag.empty()) {
    Expected<std::shared_ptr<const Recording>> recording = readRecording(opt.bag);
    if (recording) {
      opt.recording = *recording;
    } else {
      opt.recordingError = recording.error();
    }
  }
  if (int status = writeSceneFiles(opt); status != 0) return status;
  return runStudies(opt);
}

}  // namespace

int main(int argc, char** argv) {
  // The last line of defence: an unexpected exception is one line and status 3, not an abort.
  try {
    return runReport(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "fem_cloth_report: " << e.what() << '\n';
    return 3;
  }
}
