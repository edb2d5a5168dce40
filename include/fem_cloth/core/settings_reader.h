// The keys of one map of a scene as the IO layer reads them: the core reads no YAML itself.
// Integrators read their keys under `integrator` through it (integrators/registry.h), obstacle
// shapes theirs in an `obstacles` entry (contact/shapes.h).
#pragma once

#include <Eigen/Core>
#include <string>

#include "fem_cloth/core/expected.h"

namespace fem_cloth {

/// Each reader leaves `out` untouched when the key is absent and returns an error naming the key
/// when its value has the wrong type.
class SettingsReader {
 public:
  virtual ~SettingsReader() = default;
  virtual Status number(const std::string& key, double& out) const = 0;
  virtual Status integer(const std::string& key, int& out) const = 0;
  virtual Status boolean(const std::string& key, bool& out) const = 0;
  virtual Status text(const std::string& key, std::string& out) const = 0;
  /// A vector of 2 or 3 numbers (a missing z is 0).
  virtual Status vector(const std::string& key, Eigen::Vector3d& out) const = 0;
  /// The key is given, with or without a value (the readers above refuse one without).
  virtual bool has(const std::string& key) const = 0;
  /// The full path of a key, for messages ("integrator.linear_solver").
  virtual std::string where(const std::string& key) const = 0;
};

}  // namespace fem_cloth
