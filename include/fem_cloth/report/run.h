// Runs of the accuracy and stability report: one scene document stepped to a given time, with the
// wall time of the steps alone, positions sampled on a fixed time grid, and what the report
// classifies a run by (step failures, rollbacks, energy growth, smallest area ratio, stretch).
// Errors against a reference run are measured here too, and references are cached on disk.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "fem_cloth/core/conventions.h"
#include "fem_cloth/core/expected.h"
#include "fem_cloth/io/recording.h"

namespace fem_cloth::report {

struct RunRequest {
  YAML::Node scene;  ///< the complete scene document (integrator and dt included)
  /// A recorded run whose commands and frames drive the scene (the ROS side's reader gives it:
  /// the node's SimulationDriver fed from a bag); null: the scene's own pins and forces only.
  std::shared_ptr<const Recording> commands;
  double recordedDt = 0.0;  ///< the recording's step (s), which fixes its time origin
  double duration = 0.0;    ///< s; 0: the scene's duration
  /// Positions are kept every sampleInterval seconds of simulated time (must be a multiple of
  /// dt); 0: only the first and the last state.
  double sampleInterval = 0.0;
  /// Stop with Outcome::OverBudget once the steps have taken this much wall time (s).
  double wallBudget = std::numeric_limits<double>::infinity();
};

struct RunResult {
  enum class Outcome {
    Completed,   ///< every step succeeded
    Failed,      ///< a step failed (error says why); the state is the last good one
    BuildError,  ///< the scene did not build (error says why)
    NonFinite,   ///< a non-finite state or energy was seen: a bug, never expected
    OverBudget,  ///< stopped at wallBudget
  };
  Outcome outcome = Outcome::Completed;
  std::string error;
  std::string integrator;   ///< the integrator's own name
  double wall = 0.0;        ///< s spent inside step() (building and measuring excluded)
  double simulated = 0.0;   ///< s reached
  std::uint64_t steps = 0;  ///< successful steps
  std::uint64_t substeps = 0, maxSubsteps = 0, rollbacks = 0, newtonIterations = 0;
  int dim = 3;
  double clothSize = 0.0;    ///< rest bounding-box diagonal (m)
  double weightScale = 0.0;  ///< total weight x cloth size (J)
  /// Positions at t = k sampleInterval, k = 0, 1, ... as far as the run got.
  std::vector<VectorX> samples;
  std::vector<double> sampleTimes;
  /// Energy-balance error (Simulator::energies().balanceError, J) at each sample.
  std::vector<double> sampleBalance;
  double balanceEnd = 0.0;     ///< J
  double balanceMaxAbs = 0.0;  ///< largest |balance error| over all steps (J)
  /// Largest balance error over all steps as a fraction of the largest energy the run held
  /// (kinetic + elastic, the input work, or weight x size, whichever is largest): energy
  /// created by the method. Zero or negative for a dissipative method.
  double energyGrowth = 0.0;
  /// stateHash of the final positions and velocities (as ClothState.state_hash): equal hashes
  /// mean bit-identical runs.
  std::string finalHash;
  double maxStretch = 0.0;  ///< largest edge stretch l/L - 1 over all steps
  double minJ = std::numeric_limits<double>::infinity();  ///< smallest area ratio over all steps
  double minJEnd = std::numeric_limits<double>::infinity();  ///< smallest area ratio at the end
};

std::string outcomeName(RunResult::Outcome outcome);

/// Builds and runs the scene. Never throws for a bad scene: that is Outcome::BuildError, as is a
/// duration or sample interval that is not a whole number of steps.
RunResult runScene(const RunRequest& request);

/// The CFL bound 2 / omega_max (s) of a scene at its initial state, omega_max the highest natural
/// frequency of the free DOFs (SymplecticEuler::stableStep); an error if it does not build.
Expected<double> cflBound(const YAML::Node& scene);

/// Whether `interval` is a whole number (>= 1) of steps dt, to 1e-9 relative.
bool wholeSteps(double interval, double dt);

/// Position error of a run against a reference on the same sample grid, per sample: RMS and
/// largest vertex distance divided by the cloth size (relative, dimensionless).
struct PositionErrors {
  std::vector<double> rms, max;  ///< per sample (as many as both runs have)
  double rmsEnd = 0.0, maxEnd = 0.0;        ///< at the last common sample
  double rmsOverTime = 0.0, maxOverTime = 0.0;  ///< largest over the samples
};
PositionErrors positionErrors(const std::vector<VectorX>& run, const std::vector<VectorX>& reference,
                              int dim, double clothSize);

/// Least-squares slope of log(error) against log(dt): the measured convergence order. NaN with
/// fewer than two usable (positive, finite) points.
double fittedOrder(const std::vector<double>& dts, const std::vector<double>& errors);

/// A reference run, computed or read back from the cache.
struct Reference {
  RunResult run;        ///< samples, balance, stretch and wall time of the reference
  std::string key;      ///< 16 hex digits: hash of everything the run depends on
  bool cached = false;  ///< read from the cache rather than computed
};

/// Runs `request` unless the cache folder holds a run with the same key (the scene text, the
/// duration and sample grid, the commands bag's bytes and a format version); stores it after a
/// successful computation. An empty cacheDir disables the cache.
Expected<Reference> cachedReference(const RunRequest& request, const std::string& commandsBag,
                                    const std::string& cacheDir);

/// 64-bit FNV-1a of a byte string, as 16 hex digits.
std::string hashText(const std::string& text);

}  // namespace fem_cloth::report
