#include "fem_cloth/report/stability.h"

#include "fem_cloth/io/scene_yaml.h"

namespace fem_cloth::report {

const std::vector<std::string>& verdictNames() {
  static const std::vector<std::string> names = {"stable",      "recovered", "failed",
                                                 "n/a", "too_slow",  "non_finite"};
  return names;
}

CellResult runCell(const Cell& cell, int n, double wallBudget) {
  CellResult c;
  Expected<YAML::Node> doc = cellScene(cell, n);
  if (!doc) {
    c.verdict = "failed";
    c.run.outcome = RunResult::Outcome::BuildError;
    c.run.error = doc.error();
    return c;
  }
  c.duration = (*doc)["duration"].as<double>();
  RunRequest request;
  request.scene = *doc;
  request.duration = c.duration;
  request.wallBudget = wallBudget;
  c.run = runScene(request);
  switch (c.run.outcome) {
    case RunResult::Outcome::Completed: c.verdict = c.run.rollbacks > 0 ? "recovered" : "stable"; break;
    case RunResult::Outcome::Failed: c.verdict = "failed"; break;
    case RunResult::Outcome::NonFinite: c.verdict = "non_finite"; break;
    case RunResult::Outcome::OverBudget: c.verdict = "too_slow"; break;
    case RunResult::Outcome::BuildError: {
      // n/a when this integrator refuses the scene's settings at load (projective dynamics takes
      // ARAP cloth only) while backward Euler accepts them: the cell does not apply. Otherwise
      // the case itself is refused (e.g. Neo-Hookean starting inverted): a clear error, "failed".
      Cell probe = cell;
      probe.integrator = "backward_euler";
      const bool refusedHere = !parseScene(*doc);
      bool loadsWithBackwardEuler = false;
      if (Expected<YAML::Node> probeDoc = cellScene(probe, n)) {
        loadsWithBackwardEuler = parseScene(*probeDoc).ok();
      }
      c.verdict = refusedHere && loadsWithBackwardEuler ? "n/a" : "failed";
      break;
    }
  }
  return c;
}

}  // namespace fem_cloth::report
