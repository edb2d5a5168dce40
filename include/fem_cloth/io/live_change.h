// Which scene keys a running simulation can change (core/live_change.h), and a scene document
// changed by key=value pairs, validated exactly as a scene is (docs/scenes.md, Live changes).
#pragma once

#include <yaml-cpp/yaml.h>

#include <string>
#include <vector>

#include "fem_cloth/core/expected.h"
#include "fem_cloth/core/scene.h"

namespace fem_cloth {

/// material.youngs_modulus, material.poisson_ratio, material.mu, material.lambda,
/// bending.stiffness, damping.mass, damping.stiffness, gravity, contact.self_friction,
/// obstacles.<k>.friction.
bool isLiveKey(const std::string& key);
/// The live keys, for messages.
std::string liveKeysText();

struct LiveChange {
  YAML::Node document;  ///< the changed scene document
  Scene scene;          ///< parsed and validated
};

/// `document` with the `key=value` pairs applied, in order. All or nothing: the error names the
/// first pair that is malformed, names a key that cannot change while running, or makes the
/// scene invalid (with the scene's own message, which names the key).
Expected<LiveChange> applyLiveChange(const YAML::Node& document, const std::vector<std::string>& pairs,
                                     const std::string& sourcePath = "");

/// What an obstacle command does to the document's obstacles list.
enum class ObstacleEdit { Add, Remove, Move };

/// `document` with obstacle `name` added (`entry`: its scene entry as a YAML map, without a name
/// or with this one), removed, or moved (the keys of `entry` replace the obstacle's). All or
/// nothing, validated as a scene; the error names what is wrong.
Expected<LiveChange> applyObstacleChange(const YAML::Node& document, ObstacleEdit change,
                                         const std::string& name, const std::string& entry,
                                         const std::string& sourcePath = "");

}  // namespace fem_cloth
