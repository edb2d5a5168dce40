#include "fem_cloth/report/stability.h"

#include <cmath>
#include <sstream>

#include "fem_cloth/core/expected.h"
#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/validate/uniaxial.h"

namespace fem_cloth::report {

namespace {

// The strip's end state x (a StripCase grid) against physics: pulled, it ends longer than at rest,
// and the middle of the strip, columns 7-13 (a strip width and more from the clamp, which keeps
// the width from contracting), is stretched by the material's uniaxial closed form for the
// tension T = force / width, to 5 % of the strain.
Status checkStrip(const Cell& cell, const VectorX& x) {
  using S = StripCase;
  auto along = [&](int row, int col) { return x[3 * (row * S::cols + col)]; };
  double end = 0.0, axial = 0.0;
  const int c1 = 7, c2 = 13;
  const double spacing = S::length / (S::cols - 1);
  for (int r = 0; r < S::rows; ++r) {
    end += along(r, S::cols - 1) / S::rows;
    axial += (along(r, c2) - along(r, c1)) / ((c2 - c1) * spacing) / S::rows;
  }
  std::ostringstream msg;
  if (!(end > S::length)) {
    msg << "pulled by " << S::force << " N, the strip ends shorter than at rest: its loaded end at x = "
        << end << " m, rest length " << S::length << " m";
    return Error{msg.str()};
  }
  double youngsThickness = 0.0, poisson = 0.0;
  for (const Stiffness& level : stiffnessLevels()) {
    if (level.name == cell.stiffness) {
      youngsThickness = level.youngsModulus * S::thickness;
      poisson = level.poissonRatio;
    }
  }
  // Plane-stress membrane moduli (docs/materials.md).
  const double mu = youngsThickness / (2.0 * (1.0 + poisson));
  const double lambda = youngsThickness * poisson / (1.0 - poisson * poisson);
  const validate::UniaxialState expected =
      validate::uniaxialAtStress(cell.material, mu, lambda, S::force / S::width);
  const double strain = axial - 1.0, expectedStrain = expected.stretch - 1.0;
  if (!(std::abs(strain - expectedStrain) <= 0.05 * expectedStrain)) {
    msg << "the strip's stretch " << strain << " is not the uniaxial closed form " << expectedStrain
        << " of " << cell.material << " (off by " << 100.0 * (strain / expectedStrain - 1.0)
        << " %, at most 5 % accepted)";
    return Error{msg.str()};
  }
  return Status::success();
}

}  // namespace

Status checkCompleted(const Cell& cell, const RunResult& run) {
  if (!(run.energyGrowth <= kWrongEnergyGrowth)) {
    std::ostringstream msg;
    msg << "the run created " << 100.0 * run.energyGrowth << " % of its energy scale beyond the work put in"
        << " (at most " << 100.0 * kWrongEnergyGrowth << " % accepted)";
    return Error{msg.str()};
  }
  if (cell.caseName == "strip" && !run.samples.empty()) return checkStrip(cell, run.samples.back());
  return Status::success();
}

const std::vector<std::string>& verdictNames() {
  static const std::vector<std::string> names = {"stable", "recovered", "failed",    "n/a",
                                                 "wrong",  "too_slow",  "non_finite"};
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
    case RunResult::Outcome::Completed:
      if (Status s = checkCompleted(cell, c.run); !s) {
        c.verdict = "wrong";
        c.run.error = "accepted, but " + s.error();
      } else {
        c.verdict = c.run.rollbacks > 0 ? "recovered" : "stable";
      }
      break;
    case RunResult::Outcome::Failed: c.verdict = "failed"; break;
    case RunResult::Outcome::NonFinite: c.verdict = "non_finite"; break;
    case RunResult::Outcome::OverBudget: c.verdict = "too_slow"; break;
    case RunResult::Outcome::BuildError: {
      // n/a when the integrator does not support what the scene asks for (integrator registry:
      // projective dynamics takes ARAP cloth only), asked of the same cell as a scene that
      // backward Euler, which supports every material, loads: the cell does not apply.
      // Otherwise the case itself is refused (e.g. Neo-Hookean starting inverted): a clear
      // error, "failed".
      Cell probe = cell;
      probe.integrator = "backward_euler";
      bool unsupported = false;
      if (Expected<YAML::Node> probeDoc = cellScene(probe, n)) {
        if (Expected<Scene> scene = parseScene(*probeDoc)) {
          scene->integrator = cell.integrator;
          unsupported = !checkIntegratorSupports(*scene);
        }
      }
      c.verdict = unsupported ? "n/a" : "failed";
      break;
    }
  }
  return c;
}

}  // namespace fem_cloth::report
