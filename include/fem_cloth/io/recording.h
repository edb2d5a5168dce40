// A recorded run as the accuracy report replays it, behind an interface the report does not own:
// the ROS side reads bags and implements it (bag_replay.h, readRecording), so the report library
// builds on the ROS-free core and scene reader alone, and the report tool hands it a reader.
#pragma once

#include <yaml-cpp/yaml.h>

#include <memory>
#include <string>

#include "fem_cloth/core/scene.h"
#include "fem_cloth/core/simulator.h"

namespace fem_cloth {

/// A simulation stepped by something beside its own scene script (a recording's commands and
/// frames).
class DrivenSimulation {
 public:
  virtual ~DrivenSimulation() = default;
  /// The simulator now: a live change among the commands replaces it, so ask again after step().
  virtual Simulator& simulator() = 0;
  /// One step, with the commands and frame poses due before it applied.
  virtual StepReport step() = 0;
};

class Recording {
 public:
  virtual ~Recording() = default;
  virtual const std::string& path() const = 0;
  /// The scene document the run was recorded with; the error names the bag when it holds none
  /// or one that is not YAML.
  virtual Expected<YAML::Node> scene() const = 0;
  /// Simulated time (s) from the first to the last recorded state.
  virtual double recordedDuration() const = 0;
  /// `simulation` (built from `document`, which live changes in the recording change) driven by
  /// the recording's commands and frames, on the recording's time grid (its states and
  /// `recordedDt`, the step it was recorded with, fix the time origin). A command rejected now
  /// was rejected live as well: it is skipped, as the node did.
  virtual std::unique_ptr<DrivenSimulation> drive(Simulation simulation, const YAML::Node& document,
                                                  double recordedDt) const = 0;
};

}  // namespace fem_cloth
