#include "fem_cloth/io/live_change.h"

#include <regex>

#include "fem_cloth/io/scene_yaml.h"

namespace fem_cloth {

namespace {

const std::vector<std::string>& liveKeys() {
  static const std::vector<std::string> keys = {
      "material.youngs_modulus", "material.poisson_ratio", "material.mu",       "material.lambda",
      "bending.stiffness",       "damping.mass",           "damping.stiffness", "gravity",
      "contact.self_friction",   "air.density",            "air.normal_drag",   "air.tangential_drag",
      "air.wind",                "contact.surface_tolerance"};
  return keys;
}

}  // namespace

bool isLiveKey(const std::string& key) {
  static const std::regex obstacleFriction(R"(obstacles\.[0-9]+\.friction)");
  for (const std::string& k : liveKeys()) {
    if (key == k) return true;
  }
  return std::regex_match(key, obstacleFriction);
}

std::string liveKeysText() {
  std::string text;
  for (const std::string& k : liveKeys()) text += k + ", ";
  return text + "obstacles.<k>.friction";
}

Expected<LiveChange> applyLiveChange(const YAML::Node& document, const std::vector<std::string>& pairs,
                                     const std::string& sourcePath) {
  if (pairs.empty()) return Error{"no key=value pairs given"};
  LiveChange change;
  change.document = YAML::Clone(document);
  for (const std::string& pair : pairs) {
    const std::size_t eq = pair.find('=');
    if (eq == std::string::npos || eq == 0) return Error{"'" + pair + "' is not key=value"};
    const std::string key = pair.substr(0, eq);
    if (!isLiveKey(key)) {
      return Error{"'" + key + "' cannot change while running (live keys: " + liveKeysText() + ")"};
    }
    if (Status s = applySceneOverride(change.document, pair); !s) return Error{s.error()};
  }
  Expected<Scene> scene = parseScene(change.document, sourcePath);
  if (!scene) return Error{scene.error()};
  change.scene = std::move(scene).value();
  return change;
}

namespace {

// The index of the obstacle called `name` in `obstacles`, or -1.
long obstacleIndex(const YAML::Node& obstacles, const std::string& name) {
  if (!obstacles.IsSequence()) return -1;
  for (std::size_t k = 0; k < obstacles.size(); ++k) {
    if (obstacles[k]["name"] && obstacles[k]["name"].as<std::string>("") == name) return static_cast<long>(k);
  }
  return -1;
}

// The entry as a map: one YAML document (a second one was ignored), without a name or with
// the command's (another name was overwritten when adding, and renamed the obstacle when moving).
Expected<YAML::Node> entryMap(const std::string& entry, const std::string& name) {
  YAML::Node map;
  try {
    const std::vector<YAML::Node> documents = YAML::LoadAll(entry);
    if (documents.size() > 1) {
      return Error{"obstacle '" + name + "': entry holds " + std::to_string(documents.size()) +
                   " YAML documents (separated by ---): give one map"};
    }
    if (!documents.empty()) map = documents.front();
  } catch (const YAML::Exception& e) {
    return Error{"obstacle '" + name + "': entry is not valid YAML: " + e.msg};
  }
  if (!map.IsMap()) return Error{"obstacle '" + name + "': entry must be a YAML map, got '" + entry + "'"};
  if (const YAML::Node own = map["name"]; own && !(own.IsScalar() && own.Scalar() == name)) {
    return Error{"obstacle '" + name + "': the entry's name: " + sceneDocumentToString(own) +
                 " is not the command's name; leave name out of the entry (the command names the obstacle)"};
  }
  return map;
}

}  // namespace

Expected<LiveChange> applyObstacleChange(const YAML::Node& document, ObstacleEdit change,
                                         const std::string& name, const std::string& entry,
                                         const std::string& sourcePath) {
  if (name.empty()) return Error{"an obstacle command needs the obstacle's name"};
  LiveChange out;
  out.document = YAML::Clone(document);
  YAML::Node obstacles = out.document["obstacles"];
  const long index = obstacleIndex(obstacles, name);
  if (change != ObstacleEdit::Add && index < 0) return Error{"there is no obstacle named '" + name + "'"};
  if (change == ObstacleEdit::Add && index >= 0) return Error{"an obstacle named '" + name + "' exists already"};
  if (change == ObstacleEdit::Remove) {
    YAML::Node kept(YAML::NodeType::Sequence);
    for (std::size_t k = 0; k < obstacles.size(); ++k) {
      if (static_cast<long>(k) != index) kept.push_back(obstacles[k]);
    }
    out.document["obstacles"] = kept;
  } else {
    Expected<YAML::Node> map = entryMap(entry, name);
    if (!map) return Error{map.error()};
    if (change == ObstacleEdit::Add) {
      (*map)["name"] = name;
      if (!obstacles.IsSequence()) out.document["obstacles"] = YAML::Node(YAML::NodeType::Sequence);
      out.document["obstacles"].push_back(*map);
    } else {
      YAML::Node target = obstacles[static_cast<std::size_t>(index)];
      for (const auto& kv : *map) target[kv.first.as<std::string>()] = kv.second;
    }
  }
  Expected<Scene> scene = parseScene(out.document, sourcePath);
  if (!scene) return Error{scene.error()};
  out.scene = std::move(scene).value();
  return out;
}

}  // namespace fem_cloth
