#include "fem_cloth/core/materials/materials.h"

namespace fem_cloth {

const std::vector<std::string>& materialNames() {
  static const std::vector<std::string> names = {
      LinearElasticity::kName, StVenantKirchhoff::kName, Corotational::kName,
      Arap::kName,             NeoHookean::kName,        StableNeoHookean::kName};
  return names;
}

const std::vector<std::string>& materialsWithConstraintForm() {
  static const std::vector<std::string> names = namesWithConstraintForm<Material>();
  return names;
}

Expected<Material> makeMaterial(const std::string& name, const Lame& lame) {
  if (name == LinearElasticity::kName) return Material(LinearElasticity(lame));
  if (name == StVenantKirchhoff::kName) return Material(StVenantKirchhoff(lame));
  if (name == Corotational::kName) return Material(Corotational(lame));
  if (name == Arap::kName) return Material(Arap(lame));
  if (name == NeoHookean::kName) return Material(NeoHookean(lame));
  if (name == StableNeoHookean::kName) return Material(StableNeoHookean(lame));
  std::string known;
  for (const std::string& n : materialNames()) known += (known.empty() ? "" : ", ") + n;
  return Error{"unknown material model '" + name + "' (known: " + known + ")"};
}

std::string materialName(const Material& material) {
  return std::visit([](const auto& m) { return std::string(m.kName); }, material);
}

bool materialNeedsPolar(const Material& material) {
  return std::visit([](const auto& m) { return m.kNeedsPolar; }, material);
}

}  // namespace fem_cloth
