#include "fem_cloth/core/contact/shapes.h"

#include "fem_cloth/core/enum_names.h"

namespace fem_cloth {

const std::vector<std::string>& shapeTypeNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const ShapeEntry& e : shapeRegistry()) out.push_back(e.name);
    return out;
  }();
  return names;
}

std::string shapeTypeName(ShapeType type) { return enumName(shapeTypeNames(), type); }

std::optional<ShapeType> shapeTypeFromName(const std::string& name) {
  return enumFromName<ShapeType>(shapeTypeNames(), name);
}

}  // namespace fem_cloth
