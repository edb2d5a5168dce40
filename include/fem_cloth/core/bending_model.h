// The bending models a scene can name (`bending.model`; docs/bending.md), apart from the
// bending terms themselves (bending.h) so that capabilities (integrators/registry.h) can name
// them without the terms.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "fem_cloth/core/enum_names.h"

namespace fem_cloth {

/// midedge (the default, bending_midedge.h), quadratic, dihedral (bending.h).
enum class BendingModel { Midedge, Quadratic, Dihedral };

/// The names used in scenes, in the order of BendingModel: midedge, quadratic, dihedral.
inline const std::vector<std::string>& bendingModelNames() {
  static const std::vector<std::string> names = {"midedge", "quadratic", "dihedral"};
  return names;
}

inline const std::string& bendingModelName(BendingModel model) {
  return enumName(bendingModelNames(), model);
}

/// The model called `name`, if there is one.
inline std::optional<BendingModel> bendingModelFromName(const std::string& name) {
  return enumFromName<BendingModel>(bendingModelNames(), name);
}

}  // namespace fem_cloth
