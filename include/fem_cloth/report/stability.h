// A cell of the stability matrix, run and classified (docs/accuracy.md, "Stability matrix").
#pragma once

#include <string>
#include <vector>

#include "fem_cloth/report/cases.h"
#include "fem_cloth/report/run.h"

namespace fem_cloth::report {

/// The verdicts, in the order tables list them:
///   stable       every step succeeded at the first attempt;
///   recovered    every step succeeded, some after rollbacks (RunResult::rollbacks says how many);
///   failed       a step failed after its retries, or the case does not build with backward
///                Euler either (e.g. Neo-Hookean with inverted elements): the error says why;
///   n/a          this integrator refuses the cell's settings when the scene is loaded while
///                backward Euler accepts them (projective dynamics with a material other than
///                ARAP, or on a planar sheet): the cell does not apply; the error says why;
///   too_slow     stopped at the cell's wall-time budget;
///   non_finite   a non-finite state or energy was seen: a bug, which must never happen.
const std::vector<std::string>& verdictNames();

struct CellResult {
  RunResult run;
  std::string verdict;
  double duration = 0.0;  ///< s, the case's horizon
};

/// Runs the cell (an n x n mesh) for its case's duration and classifies it.
CellResult runCell(const Cell& cell, int n, double wallBudget);

}  // namespace fem_cloth::report
