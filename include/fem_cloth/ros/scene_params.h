// Scenes from the ROS parameter server, in the same YAML format as fem_cloth_sim's files.
#pragma once

#include <ros/node_handle.h>
#include <yaml-cpp/yaml.h>

#include <string>
#include <vector>

#include "fem_cloth/core/expected.h"

namespace fem_cloth {

/// Reads an optional private parameter of type T, checking its type: a parameter that is set
/// with the wrong type is an error naming it ("parameter ~name must be <expected>"); one that is
/// not set leaves `value` as it is.
template <typename T>
bool readParam(const ros::NodeHandle& nh, const std::string& name, T& value, std::string* error,
               const char* expected) {
  if (!nh.hasParam(name)) return true;
  if (!nh.getParam(name, value)) {
    *error = "parameter ~" + name + " must be " + expected;
    return false;
  }
  return true;
}

/// An integer parameter: a number with a fraction (5.5), which roscpp's getParam would round,
/// is an error naming it, as is any other type.
bool readParam(const ros::NodeHandle& nh, const std::string& name, int& value, std::string* error,
               const char* expected);

/// Why `frame` cannot be the tf frame of parameter `parameter` (a name, "~frame_id"): empty,
/// or with blanks or control characters (tf would take it, and nothing could name it back).
Status frameNameProblem(const std::string& frame, const std::string& parameter);

/// Converts a parameter tree into YAML (structs to maps, arrays to lists, scalars to scalars).
YAML::Node toYaml(const XmlRpc::XmlRpcValue& value);

/// The other way: YAML maps to structs, lists to arrays, scalars to booleans, whole numbers,
/// numbers or strings (as a parameter server would hold the document).
XmlRpc::XmlRpcValue toXmlRpc(const YAML::Node& node);

/// Maps of `overlay` replace or extend those of `base`, key by key; other values replace.
void overlayYaml(YAML::Node base, const YAML::Node& overlay);

/// The keys under `integrator` that the parameters (as a document) set, leaving out those that
/// repeat the scene file's own value (the same text or number): cloth.launch loads the file's
/// keys as parameters too, and a key of another integrator there is the file's (a warning), not
/// one the user set (an error).
std::vector<std::string> integratorKeysSet(const YAML::Node& parameters, const YAML::Node& file);

/// The scene document of a node: the YAML file named by the private parameter `scene_file`
/// (or `defaultSceneFile` when neither it nor any scene key is set), overlaid with every
/// private parameter that is not one of `nodeKeys`, so that a launch file's `rosparam load` of a
/// scene, or a single `<param>`, sets or overrides scene keys. sourcePath receives the file used
/// (relative mesh files resolve against it). A parameter under ~integrator/ that the document's
/// integrator does not read is an error naming it (checkGivenIntegratorKeys), unless it repeats
/// the scene file's own value (cloth.launch loads the file's keys as parameters as well): a key
/// of the file is a warning (Scene::warnings).
Expected<YAML::Node> sceneDocumentFromParameters(const ros::NodeHandle& privateNode,
                                                 const std::vector<std::string>& nodeKeys,
                                                 const std::string& defaultSceneFile,
                                                 std::string* sourcePath);

}  // namespace fem_cloth
