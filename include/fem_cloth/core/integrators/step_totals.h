// What the steps of a run did, summed over them (StepReport): the solvers' counts and times, the
// worst error and the deepest reach into a box. fem_cloth_sim's summary prints it, for a scene run
// and for a run into a bag (runToBag) alike.
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>

#include "fem_cloth/core/integrators/integrator.h"

namespace fem_cloth {

struct StepTotals {
  std::uint64_t steps = 0;  ///< accepted steps
  std::uint64_t newtonIterations = 0;
  std::uint64_t quasiNewtonIterations = 0;  ///< integrator.solver: lbfgs
  std::uint64_t solverFallbacks = 0;        ///< of its substeps, the ones Newton finished
  std::uint64_t localIterations = 0;        ///< XPBD sweeps, projective dynamics iterations
  std::uint64_t backtracks = 0;
  std::uint64_t rollbacks = 0;
  std::uint64_t tightened = 0;  ///< of the rollbacks: re-solved 100x tighter (Simulator::step)
  std::uint64_t substeps = 0;
  std::uint64_t failures = 0;
  double maxResidual = 0.0;       ///< N
  DisplacementError worstError;   ///< acceptance test (a) in displacement (implicit steppers)
  NewtonTimes newtonTimes;
  /// The deepest the cloth's surface reached into a box between its vertices (m, StepReport),
  /// where, and in which step (counted from 1).
  double boxDepth = 0.0;
  std::string boxDepthWhere;
  std::uint64_t boxDepthStep = 0;

  /// Counts an accepted step.
  void addStep(const StepReport& r) {
    ++steps;
    if (r.boxDepth > boxDepth) {
      boxDepth = r.boxDepth;
      boxDepthWhere = r.boxDepthWhere;
      boxDepthStep = steps;
    }
    newtonIterations += static_cast<std::uint64_t>(r.newtonIterations);
    quasiNewtonIterations += static_cast<std::uint64_t>(r.quasiNewtonIterations);
    solverFallbacks += static_cast<std::uint64_t>(r.solverFallbacks);
    localIterations += static_cast<std::uint64_t>(r.iterations);
    backtracks += static_cast<std::uint64_t>(r.lineSearchBacktracks);
    newtonTimes += r.newtonTimes;
    rollbacks += static_cast<std::uint64_t>(r.rollbacks);
    tightened += static_cast<std::uint64_t>(r.tightened);
    substeps += static_cast<std::uint64_t>(r.substeps);
    maxResidual = std::max(maxResidual, r.residual);
    worstError.merge(r.displacement);
  }
  /// Counts a step that failed (its attempts were rolled back; the run stops there).
  void addFailure(const StepReport& r) {
    ++failures;
    rollbacks += static_cast<std::uint64_t>(r.rollbacks);
  }
};

}  // namespace fem_cloth
