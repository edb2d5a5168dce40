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
///   wrong        every step was accepted, but the result is not right: the run created more
///                than kWrongEnergyGrowth of its energy scale beyond the work put in
///                (RunResult::energyGrowth), or its case's closed form is violated (the strip:
///                it ends shorter than at rest, or its stretch is off the material's uniaxial
///                closed form by more than 5 % of the strain); the error says which;
///   too_slow     stopped at the cell's wall-time budget;
///   non_finite   a non-finite state or energy was seen: a bug, which must never happen.
const std::vector<std::string>& verdictNames();

/// Energy a completed run may have created, as a fraction of its energy scale, before it is
/// "wrong": each accepted step creates at most 1e-3 of it (acceptance test (b)); symplectic
/// Euler's measured energy swings around its modified energy by more, within a few per cent.
constexpr double kWrongEnergyGrowth = 0.05;

struct CellResult {
  RunResult run;
  std::string verdict;
  double duration = 0.0;  ///< s, the case's horizon
};

/// Whether a completed run of the cell is right (success) or "wrong" (the error says why).
Status checkCompleted(const Cell& cell, const RunResult& run);

/// Runs the cell (an n x n mesh) for its case's duration and classifies it.
CellResult runCell(const Cell& cell, int n, double wallBudget);

}  // namespace fem_cloth::report
