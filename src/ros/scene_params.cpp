#include "fem_cloth/ros/scene_params.h"

#include <algorithm>
#include <cctype>
#include <sstream>

#include "fem_cloth/io/scene_yaml.h"

namespace fem_cloth {

bool readParam(const ros::NodeHandle& nh, const std::string& name, int& value, std::string* error,
               const char* expected) {
  if (!nh.hasParam(name)) return true;
  XmlRpc::XmlRpcValue v;
  if (!nh.getParam(name, v) || v.getType() != XmlRpc::XmlRpcValue::TypeInt) {
    const YAML::Node got = toYaml(v);
    *error = "parameter ~" + name + " must be " + expected + ", got " +
             (got.IsScalar() ? "'" + printableText(got.Scalar(), 100) + "'" : std::string("a list or map"));
    return false;
  }
  value = static_cast<int>(v);
  return true;
}

Status frameNameProblem(const std::string& frame, const std::string& parameter) {
  if (frame.empty()) return Error{"parameter " + parameter + " must be a frame name, got an empty one"};
  for (char c : frame) {
    if (std::isspace(static_cast<unsigned char>(c)) || std::iscntrl(static_cast<unsigned char>(c))) {
      return Error{"parameter " + parameter + " must be a frame name without blanks or control characters, got '" +
                   printableText(frame, 100) + "'"};
    }
  }
  return Status::success();
}

YAML::Node toYaml(const XmlRpc::XmlRpcValue& value) {
  XmlRpc::XmlRpcValue v = value;  // the accessors are not const
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeStruct: {
      YAML::Node map(YAML::NodeType::Map);
      for (auto it = v.begin(); it != v.end(); ++it) map[it->first] = toYaml(it->second);
      return map;
    }
    case XmlRpc::XmlRpcValue::TypeArray: {
      YAML::Node list(YAML::NodeType::Sequence);
      for (int i = 0; i < v.size(); ++i) list.push_back(toYaml(v[i]));
      return list;
    }
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return YAML::Node(static_cast<bool>(v));
    case XmlRpc::XmlRpcValue::TypeInt:
      return YAML::Node(static_cast<int>(v));
    case XmlRpc::XmlRpcValue::TypeDouble: {
      std::ostringstream s;
      s.precision(17);
      s << static_cast<double>(v);
      return YAML::Node(s.str());
    }
    case XmlRpc::XmlRpcValue::TypeString:
      return YAML::Node(static_cast<std::string>(v));
    default:
      return YAML::Node();
  }
}

XmlRpc::XmlRpcValue toXmlRpc(const YAML::Node& node) {
  XmlRpc::XmlRpcValue out;
  if (node.IsMap()) {
    for (const auto& kv : node) out[kv.first.as<std::string>()] = toXmlRpc(kv.second);
  } else if (node.IsSequence()) {
    out.setSize(static_cast<int>(node.size()));
    for (std::size_t k = 0; k < node.size(); ++k) out[static_cast<int>(k)] = toXmlRpc(node[k]);
  } else if (node.IsScalar()) {
    // As the YAML loader of rosparam types them: booleans, then integers, then doubles.
    const std::string& text = node.Scalar();
    bool b = false;
    int i = 0;
    double d = 0.0;
    if (YAML::convert<bool>::decode(node, b)) {
      out = b;
    } else if (text.find_first_of(".eE") == std::string::npos && YAML::convert<int>::decode(node, i)) {
      out = i;
    } else if (YAML::convert<double>::decode(node, d)) {
      out = d;
    } else {
      out = text;
    }
  }
  return out;
}

void overlayYaml(YAML::Node base, const YAML::Node& overlay) {
  for (const auto& kv : overlay) {
    const std::string key = kv.first.as<std::string>();
    YAML::Node existing = base[key];
    if (kv.second.IsMap() && existing.IsDefined() && existing.IsMap()) {
      overlayYaml(existing, kv.second);
    } else {
      base[key] = kv.second;
    }
  }
}

namespace {

/// The same scalar: the same text, or the same number (a parameter's double comes back as 17
/// digits: 0.9 as 0.90000000000000002).
bool sameScalar(const YAML::Node& a, const YAML::Node& b) {
  if (!a.IsDefined() || !b.IsDefined() || !a.IsScalar() || !b.IsScalar()) return false;
  if (a.Scalar() == b.Scalar()) return true;
  double x = 0.0, y = 0.0;
  return YAML::convert<double>::decode(a, x) && YAML::convert<double>::decode(b, y) && x == y;
}

}  // namespace

std::vector<std::string> integratorKeysSet(const YAML::Node& parameters, const YAML::Node& file) {
  const YAML::Node params = parameters["integrator"];
  const YAML::Node own = file["integrator"];
  std::vector<std::string> out;
  if (!params.IsDefined() || !params.IsMap()) return out;
  for (const auto& kv : params) {
    const std::string key = kv.first.Scalar();
    const bool fromFile = own.IsDefined() && own.IsMap() && sameScalar(own[key], kv.second);
    if (!fromFile) out.push_back(key);
  }
  return out;
}

Expected<YAML::Node> sceneDocumentFromParameters(const ros::NodeHandle& privateNode,
                                                 const std::vector<std::string>& nodeKeys,
                                                 const std::string& defaultSceneFile,
                                                 std::string* sourcePath) {
  XmlRpc::XmlRpcValue all;
  YAML::Node overlay(YAML::NodeType::Map);
  if (privateNode.getParam("", all) && all.getType() == XmlRpc::XmlRpcValue::TypeStruct) {
    for (auto it = all.begin(); it != all.end(); ++it) {
      if (std::find(nodeKeys.begin(), nodeKeys.end(), it->first) != nodeKeys.end()) continue;
      overlay[it->first] = toYaml(it->second);
    }
  }
  std::string file;
  privateNode.param<std::string>("scene_file", file, "");
  if (file.empty() && !overlay["mesh"].IsDefined()) file = defaultSceneFile;
  YAML::Node doc(YAML::NodeType::Map);
  if (!file.empty()) {
    Expected<YAML::Node> loaded = loadSceneDocument(file);
    if (!loaded) return Error{"~scene_file: " + loaded.error()};
    doc = *loaded;
  }
  // An integrator key set by a parameter that the integrator does not read is refused, as with
  // --set; one in the scene file is a warning (Scene::warnings).
  const std::vector<std::string> given = integratorKeysSet(overlay, doc);
  overlayYaml(doc, overlay);
  FEM_CLOTH_CHECK(checkGivenIntegratorKeys(doc, given, "parameter ~integrator/"));
  if (sourcePath != nullptr) *sourcePath = file;
  return doc;
}

}  // namespace fem_cloth
