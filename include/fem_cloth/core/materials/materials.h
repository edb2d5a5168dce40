// All material models, and a run-time choice among them.
#pragma once

#include <string>
#include <variant>
#include <vector>

#include "fem_cloth/core/expected.h"
#include "fem_cloth/core/materials/arap.h"
#include "fem_cloth/core/materials/corotational.h"
#include "fem_cloth/core/materials/linear.h"
#include "fem_cloth/core/materials/neo_hookean.h"
#include "fem_cloth/core/materials/stable_neo_hookean.h"
#include "fem_cloth/core/materials/stvk.h"

namespace fem_cloth {

/// One of the six models. Visit it once per assembly (std::visit), not once per element, so the
/// element loop is compiled for the concrete model.
using Material = std::variant<LinearElasticity, StVenantKirchhoff, Corotational, Arap, NeoHookean,
                              StableNeoHookean>;

/// The model names accepted by makeMaterial, in a fixed order: linear, stvk, corotational, arap,
/// neo_hookean, stable_neo_hookean.
const std::vector<std::string>& materialNames();

/// Builds a model by name; an unknown name is an error listing the known ones.
Expected<Material> makeMaterial(const std::string& name, const Lame& lame);

std::string materialName(const Material& material);
bool materialNeedsPolar(const Material& material);

}  // namespace fem_cloth
