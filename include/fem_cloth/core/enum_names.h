// Enums that a scene names in text (mesh.type, bending.model, obstacles[i].type): each has one
// table of names, in the order of its values, and the IO layer turns the text into the value
// once, where it reads the scene. The core compares values, never the text.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace fem_cloth {

/// The value `name` names in `names` (the table of enum E, names[i] naming value i), if any.
template <typename E>
std::optional<E> enumFromName(const std::vector<std::string>& names, const std::string& name) {
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name) return static_cast<E>(i);
  }
  return std::nullopt;
}

/// The name of `value` in its enum's table.
template <typename E>
const std::string& enumName(const std::vector<std::string>& names, E value) {
  return names[static_cast<std::size_t>(value)];
}

/// The names of `values`, in their order.
template <typename E>
std::vector<std::string> enumNames(const std::vector<std::string>& names, const std::vector<E>& values) {
  std::vector<std::string> out;
  for (const E value : values) out.push_back(enumName(names, value));
  return out;
}

}  // namespace fem_cloth
