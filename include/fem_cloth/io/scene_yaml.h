// Scenes in YAML: the one format shared by fem_cloth_sim (files and --set overrides), the node
// (ROS parameters in its private namespace, converted to the same tree) and bags (the scene is
// stored as YAML text). See docs/scenes.md for every key, its unit and default.
//
// Unknown keys and ill-typed or out-of-range values are errors that name the key.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <string>
#include <vector>

#include "fem_cloth/core/scene.h"

namespace fem_cloth {

/// The largest scene file read (bytes): far more than any scene with an explicit mesh of
/// practical size, far less than what would exhaust the memory of the YAML tree.
constexpr std::uintmax_t kMaxSceneFileBytes = 16u << 20;

/// Parses a scene's text (from a file, a bag, a parameter) into its document: at most
/// kMaxSceneFileBytes, one YAML document (a second after --- is refused, not ignored), empty
/// text an empty map. Errors start with `where`.
Expected<YAML::Node> parseSceneText(const std::string& text, const std::string& where);

/// Reads a scene document and applies `key.path=value` overrides (the value is YAML: a number,
/// a word, or a [list]) with applySceneOverrides.
Expected<YAML::Node> loadSceneDocument(const std::string& path,
                                       const std::vector<std::string>& overrides = {});
/// Applies one `key.path=value` override to a document; the path must name a known key.
Status applySceneOverride(YAML::Node& document, const std::string& assignment);
/// Applies the overrides in order, then checks with checkGivenIntegratorKeys that the
/// integrator the document ends with reads every `integrator.KEY` among them: a setting given on
/// the command line that would take no effect (integrator.iterations for backward_euler) is an
/// error naming the key, the integrator and the keys it reads.
Status applySceneOverrides(YAML::Node& document, const std::vector<std::string>& overrides);
/// Keys under `integrator` given explicitly (by `source`, which the error names followed by the
/// key: "--set integrator.", "parameter ~integrator/") must be read by the document's integrator
/// (integrator.name, or the default). Keys in the scene file itself that the integrator does not
/// read are not errors but Scene::warnings (parseScene), since a scene switched to another
/// integrator keeps its own integrator's keys.
Status checkGivenIntegratorKeys(const YAML::Node& document, const std::vector<std::string>& keys,
                                const std::string& source);
/// Converts a document into a validated Scene; sourcePath resolves relative mesh files and
/// preset files. `material: {preset: NAME}` merges a fabric preset from config/materials/
/// (docs/materials.md, "Presets") under the scene's own keys.
Expected<Scene> parseScene(const YAML::Node& document, const std::string& sourcePath = "");
/// loadSceneDocument + parseScene; `document`, when given, receives the document parsed (the
/// overrides applied).
Expected<Scene> loadScene(const std::string& path, const std::vector<std::string>& overrides = {},
                          YAML::Node* document = nullptr);
/// The document as YAML text (for storing with a run).
std::string sceneDocumentToString(const YAML::Node& document);

}  // namespace fem_cloth
