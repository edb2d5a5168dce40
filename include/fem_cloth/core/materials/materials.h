// All material models, and a run-time choice among them.
#pragma once

#include <string>
#include <type_traits>
#include <utility>
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

/// Whether a model has the optional constraint form (material.h): its kNumConstraints,
/// constraintStiffness() and constraints(). The membrane offers XPBD a constraint form only for
/// such a model.
template <class M, class = void>
struct HasConstraintForm : std::false_type {};
template <class M>
struct HasConstraintForm<M, std::void_t<decltype(M::kNumConstraints)>> : std::true_type {};
template <class M>
inline constexpr bool kHasConstraintForm = HasConstraintForm<M>::value;

/// The names (kName) of the alternatives of a variant of models that have a constraint form, in
/// the variant's order.
template <class Variant, std::size_t... I>
std::vector<std::string> namesWithConstraintForm(std::index_sequence<I...> /*alternatives*/) {
  std::vector<std::string> names;
  (
      [&names] {
        using M = std::variant_alternative_t<I, Variant>;
        if constexpr (kHasConstraintForm<M>) names.emplace_back(M::kName);
      }(),
      ...);
  return names;
}
template <class Variant>
std::vector<std::string> namesWithConstraintForm() {
  return namesWithConstraintForm<Variant>(std::make_index_sequence<std::variant_size_v<Variant>>{});
}

/// The materials XPBD can simulate: those of materialNames() with a constraint form.
const std::vector<std::string>& materialsWithConstraintForm();

/// Builds a model by name; an unknown name is an error listing the known ones.
Expected<Material> makeMaterial(const std::string& name, const Lame& lame);

std::string materialName(const Material& material);
bool materialNeedsPolar(const Material& material);

}  // namespace fem_cloth
