// A scene from config/ for the core tests that link fem_cloth_io and define FEM_CLOTH_CONFIG_DIR.
#pragma once

#include <stdexcept>
#include <string>

#include "fem_cloth/io/scene_yaml.h"

namespace fem_cloth::test {

inline Scene configScene(const std::string& file) {
  Expected<Scene> scene = loadScene(std::string(FEM_CLOTH_CONFIG_DIR) + "/" + file);
  if (!scene) throw std::runtime_error(scene.error());
  return *scene;
}

}  // namespace fem_cloth::test
