#include "fem_cloth/io/scene_yaml.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <cstdlib>
#include <functional>
#include <map>
#include <set>
#include <sstream>

#include "fem_cloth/core/package_paths.h"
#include "fem_cloth/core/text_file.h"

namespace fem_cloth {

namespace {

std::string describe(const YAML::Node& node) {
  if (!node.IsDefined() || node.IsNull()) return "no value";
  if (node.IsScalar()) return "'" + printableText(node.Scalar(), 100) + "'";
  if (node.IsSequence()) return "a list";
  return "a map";
}

// The choices of an enum as messages list them: "grid, obj or explicit".
std::string alternatives(const std::vector<std::string>& names) {
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i) {
    out += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + names[i];
  }
  return out;
}

// Reads the keys of one YAML map, remembering which were used so that unknown keys are errors.
// Integrators and obstacle shapes read their own keys through it (core/settings_reader.h).
class MapReader final : public SettingsReader {
 public:
  // A missing key gives yaml-cpp's "zombie" node, on which most calls throw: keep a null
  // node instead.
  MapReader(const YAML::Node& node, std::string path, std::vector<std::string> known)
      : node_(node.IsDefined() ? node : YAML::Node(YAML::NodeType::Null)),
        path_(std::move(path)),
        known_(std::move(known)) {}

  Status check() const {
    if (!node_.IsDefined() || node_.IsNull()) return Status::success();
    if (!node_.IsMap()) return Error{where("") + " must be a map of keys, got " + describe(node_)};
    // YAML keys are unique in a map, but yaml-cpp reads a repeated key and keeps the first
    // value, which would silently drop the second: an error as well.
    std::set<std::string> seen;
    for (const auto& kv : node_) {
      // YAML allows any node as a key (`? [a, b]: 1`); a scene's keys are words.
      if (!kv.first.IsScalar()) {
        return Error{"a key of '" + where("") + "' is " + describe(kv.first) + ", not a word"};
      }
      const std::string key = kv.first.Scalar();
      if (std::find(known_.begin(), known_.end(), key) == known_.end()) {
        return Error{"unknown key '" + where(printableText(key, 100)) + "' (known here: " + commaList(known_) + ")"};
      }
      if (!seen.insert(key).second) {
        return Error{"key '" + where(key) + "' is given more than once"};
      }
    }
    return Status::success();
  }

  /// The key is given, with or without a value: `rows:` and `rows: ~` are given with none,
  /// which the readers of values refuse (a forgotten value must not become the default).
  bool has(const std::string& key) const override { return node_.IsMap() && node_[key].IsDefined(); }
  YAML::Node child(const std::string& key) const { return node_.IsMap() ? node_[key] : YAML::Node(); }
  std::string where(const std::string& key) const override {
    if (path_.empty()) return key.empty() ? "scene" : key;
    return key.empty() ? path_ : path_ + "." + key;
  }

  Status number(const std::string& key, double& out) const override {
    if (!has(key)) return Status::success();
    return toNumber(child(key), where(key), out);
  }
  Status optionalNumber(const std::string& key, std::optional<double>& out) const {
    if (!has(key)) return Status::success();
    double v = 0.0;
    if (Status s = toNumber(child(key), where(key), v); !s) return s;
    out = v;
    return Status::success();
  }
  Status integer(const std::string& key, int& out) const override {
    if (!has(key)) return Status::success();
    return toInteger(child(key), where(key), out);
  }
  Status boolean(const std::string& key, bool& out) const override {
    if (!has(key)) return Status::success();
    const YAML::Node n = child(key);
    try {
      if (!n.IsScalar()) throw YAML::Exception(YAML::Mark(), "");
      out = n.as<bool>();
    } catch (const YAML::Exception&) {
      return Error{where(key) + " must be true or false, got " + describe(n)};
    }
    return Status::success();
  }
  Status text(const std::string& key, std::string& out) const override {
    if (!has(key)) return Status::success();
    const YAML::Node n = child(key);
    if (!n.IsScalar()) return Error{where(key) + " must be a word, got " + describe(n)};
    out = n.Scalar();
    return Status::success();
  }
  /// A word naming a value of an enum (`names`: its table, core/enum_names.h); absent, `out`
  /// keeps its value.
  template <typename E>
  Status named(const std::string& key, const std::vector<std::string>& names, E& out) const {
    std::string word = enumName(names, out);
    FEM_CLOTH_CHECK(text(key, word));
    return toEnum(word, where(key), names, out);
  }
  /// A list under `key`; not given, or given without a value (all its entries commented out),
  /// it is empty.
  Status list(const std::string& key, const std::string& what, YAML::Node& out) const {
    // reset() rebinds the handle; operator= would write into the node it refers to.
    out.reset(YAML::Node(YAML::NodeType::Sequence));
    if (!has(key) || child(key).IsNull()) return Status::success();
    if (!child(key).IsSequence()) {
      return Error{where(key) + " must be " + what + ", got " + describe(child(key))};
    }
    out.reset(child(key));
    return Status::success();
  }
  /// A vector of 2 or 3 numbers (missing z is 0).
  Status vector(const std::string& key, Eigen::Vector3d& out) const override {
    if (!has(key)) return Status::success();
    return toVector(child(key), where(key), out);
  }

  static Status toNumber(const YAML::Node& n, const std::string& name, double& out) {
    if (!n.IsScalar()) return Error{name + " must be a number, got " + describe(n)};
    try {
      out = n.as<double>();
    } catch (const YAML::Exception&) {
      return Error{name + " must be a number, got " + describe(n)};
    }
    if (!std::isfinite(out)) return Error{name + " must be finite, got " + describe(n)};
    return Status::success();
  }
  static Status toInteger(const YAML::Node& n, const std::string& name, int& out) {
    if (!n.IsScalar()) return Error{name + " must be a whole number, got " + describe(n)};
    double v = 0.0;
    if (Status s = toNumber(n, name, v); !s) return s;
    if (v != std::floor(v)) return Error{name + " must be a whole number, got " + describe(n)};
    // Within int, with room to spare for the products the validation forms (rows x cols).
    if (std::abs(v) > 1e9) {
      return Error{name + " must be a whole number of at most 10^9 in size, got " + describe(n)};
    }
    out = static_cast<int>(v);
    return Status::success();
  }
  template <typename E>
  static Status toEnum(const std::string& word, const std::string& name, const std::vector<std::string>& names,
                       E& out) {
    const std::optional<E> value = enumFromName<E>(names, word);
    if (!value) return Error{name + " must be " + alternatives(names) + ", got '" + word + "'"};
    out = *value;
    return Status::success();
  }
  static Status toVector(const YAML::Node& n, const std::string& name, Eigen::Vector3d& out) {
    if (!n.IsSequence() || n.size() < 2 || n.size() > 3) {
      return Error{name + " must be a list of 2 or 3 numbers, got " + describe(n)};
    }
    Eigen::Vector3d v = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < n.size(); ++k) {
      if (Status s = toNumber(n[k], name + "[" + std::to_string(k) + "]", v[k]); !s) return s;
    }
    out = v;
    return Status::success();
  }

 private:
  YAML::Node node_;
  std::string path_;
  std::vector<std::string> known_;
};

Status readSelection(const MapReader& r, VertexSelection& sel) {
  YAML::Node indices, pairs;
  FEM_CLOTH_CHECK(r.list("vertices", "a list of vertex indices", indices));
  for (std::size_t k = 0; k < indices.size(); ++k) {
    int v = 0;
    FEM_CLOTH_CHECK(MapReader::toInteger(indices[k], r.where("vertices") + "[" + std::to_string(k) + "]", v));
    sel.vertices.push_back(v);
  }
  FEM_CLOTH_CHECK(r.list("grid_vertices", "a list of [row, col] pairs", pairs));
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const std::string name = r.where("grid_vertices") + "[" + std::to_string(k) + "]";
    if (!pairs[k].IsSequence() || pairs[k].size() != 2) return Error{name + " must be a [row, col] pair"};
    std::array<int, 2> rc{};
    for (int j = 0; j < 2; ++j) FEM_CLOTH_CHECK(MapReader::toInteger(pairs[k][j], name, rc[j]));
    sel.gridVertices.push_back(rc);
  }
  return r.text("grid_edge", sel.gridEdge);
}

Status readMesh(const YAML::Node& node, Scene& s) {
  if (!node.IsDefined() || node.IsNull()) return Error{"mesh is required"};
  MapReader r(node, "mesh",
              {"type", "rows", "cols", "width", "height", "dim", "plane", "origin", "file",
               "vertices", "triangles", "min_quality"});
  FEM_CLOTH_CHECK(r.check());
  FEM_CLOTH_CHECK(r.named("type", meshTypeNames(), s.meshType));
  FEM_CLOTH_CHECK(r.integer("rows", s.grid.rows));
  FEM_CLOTH_CHECK(r.integer("cols", s.grid.cols));
  FEM_CLOTH_CHECK(r.number("width", s.grid.width));
  FEM_CLOTH_CHECK(r.number("height", s.grid.height));
  FEM_CLOTH_CHECK(r.integer("dim", s.dim));
  s.grid.dim = s.dim;
  std::string plane = "xy";
  FEM_CLOTH_CHECK(r.text("plane", plane));
  if (plane == "xy") {
    s.grid.plane = GridPlane::XY;
  } else if (plane == "xz") {
    s.grid.plane = GridPlane::XZ;
  } else if (plane == "yz") {
    s.grid.plane = GridPlane::YZ;
  } else {
    return Error{"mesh.plane must be xy, xz or yz, got '" + plane + "'"};
  }
  Eigen::Vector3d origin(s.grid.origin[0], s.grid.origin[1], s.grid.origin[2]);
  FEM_CLOTH_CHECK(r.vector("origin", origin));
  s.grid.origin = {origin.x(), origin.y(), origin.z()};
  FEM_CLOTH_CHECK(r.text("file", s.objFile));
  FEM_CLOTH_CHECK(r.number("min_quality", s.minTriangleQuality));
  if (r.has("vertices") || r.has("triangles")) {
    if (s.meshType != MeshType::Explicit) {
      return Error{"mesh.vertices and mesh.triangles need mesh.type explicit"};
    }
    const YAML::Node vs = r.child("vertices"), ts = r.child("triangles");
    if (!vs.IsSequence() || !ts.IsSequence()) {
      return Error{"mesh.vertices and mesh.triangles must both be lists"};
    }
    s.explicitMesh.dim = s.dim;
    s.explicitMesh.restPositions.resize(static_cast<Eigen::Index>(vs.size()) * s.dim);
    for (std::size_t i = 0; i < vs.size(); ++i) {
      Eigen::Vector3d p;
      FEM_CLOTH_CHECK(MapReader::toVector(vs[i], "mesh.vertices[" + std::to_string(i) + "]", p));
      if (s.dim == 2 && p.z() != 0.0) {
        return Error{"mesh.vertices[" + std::to_string(i) + "] has z != 0 in a planar mesh"};
      }
      s.explicitMesh.restPositions.segment(s.dim * static_cast<Eigen::Index>(i), s.dim) = p.head(s.dim);
    }
    for (std::size_t t = 0; t < ts.size(); ++t) {
      const std::string name = "mesh.triangles[" + std::to_string(t) + "]";
      if (!ts[t].IsSequence() || ts[t].size() != 3) return Error{name + " must be 3 vertex indices"};
      Triangle tri{};
      for (int k = 0; k < 3; ++k) FEM_CLOTH_CHECK(MapReader::toInteger(ts[t][k], name, tri[k]));
      s.explicitMesh.triangles.push_back(tri);
    }
  } else if (s.meshType == MeshType::Explicit) {
    return Error{"mesh.type explicit needs mesh.vertices and mesh.triangles"};
  }
  return Status::success();
}

// The keys every integrator reads, then every registered integrator's own (registry.h), so
// that all of them are checked whichever integrator the scene names.
Status readIntegrator(const YAML::Node& node, Scene& s) {
  MapReader r(node, "integrator", integratorKeys());
  FEM_CLOTH_CHECK(r.check());
  FEM_CLOTH_CHECK(r.text("name", s.integrator));
  FEM_CLOTH_CHECK(r.number("dt", s.dt));
  FEM_CLOTH_CHECK(r.integer("substeps", s.substeps));
  FEM_CLOTH_CHECK(r.integer("max_retries", s.maxRetries));
  for (const IntegratorEntry& entry : integratorRegistry()) FEM_CLOTH_CHECK(entry.read(r, s));
  if (node.IsDefined() && node.IsMap()) {
    for (const auto& kv : node) {
      const std::string note = unusedIntegratorKeyNote(s.integrator, kv.first.Scalar());
      if (!note.empty()) s.warnings.push_back(note);
    }
  }
  return Status::success();
}

// A scripted motion (the `trajectory` key of r): a list of {time (s), offset (m)}.
Status readTrajectory(const MapReader& r, std::vector<TrajectoryPoint>& out) {
  YAML::Node points;
  FEM_CLOTH_CHECK(r.list("trajectory", "a list of {time, offset}", points));
  for (std::size_t k = 0; k < points.size(); ++k) {
    const std::string at = r.where("trajectory") + "[" + std::to_string(k) + "]";
    MapReader p(points[k], at, {"time", "offset"});
    FEM_CLOTH_CHECK(p.check());
    if (!p.has("time") || !p.has("offset")) return Error{at + " needs time and offset"};
    TrajectoryPoint point;
    FEM_CLOTH_CHECK(p.number("time", point.time));
    FEM_CLOTH_CHECK(p.vector("offset", point.offset));
    out.push_back(point);
  }
  return Status::success();
}

// Obstacles: the keys allowed depend on the type (its shape's entry, core/contact/shapes.h), so a
// key of another shape is an error naming the keys this one takes.
Status readObstacles(const MapReader& root, Scene& s) {
  YAML::Node list;
  FEM_CLOTH_CHECK(root.list("obstacles", "a list of obstacles", list));
  const std::vector<std::string> common = {"name", "type", "friction", "frame", "velocity", "trajectory"};
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string key = "obstacles[" + std::to_string(i) + "]";
    const YAML::Node node = list[i];
    if (!node.IsMap()) return Error{key + " must be a map of keys, got " + describe(node)};
    const YAML::Node typeNode = node["type"];
    if (!typeNode.IsDefined() || !typeNode.IsScalar()) {
      return Error{key + ".type is required: " + alternatives(shapeTypeNames())};
    }
    SceneObstacle o;
    FEM_CLOTH_CHECK(MapReader::toEnum(typeNode.Scalar(), key + ".type", shapeTypeNames(), o.type));
    const ShapeEntry& shape = shapeEntry(o.type);
    std::vector<std::string> known = common;
    known.insert(known.end(), shape.keys.begin(), shape.keys.end());
    MapReader r(node, key, known);
    FEM_CLOTH_CHECK(r.check());
    o.name = "obstacle_" + std::to_string(i);
    FEM_CLOTH_CHECK(r.text("name", o.name));
    FEM_CLOTH_CHECK(shape.read(r, o));
    FEM_CLOTH_CHECK(r.number("friction", o.friction));
    FEM_CLOTH_CHECK(r.text("frame", o.frame));
    FEM_CLOTH_CHECK(r.vector("velocity", o.velocity));
    FEM_CLOTH_CHECK(readTrajectory(r, o.trajectory));
    s.obstacles.push_back(o);
  }
  return Status::success();
}

// frames: [{name: corner, vertex: 0}, {name: other, grid_vertex: [0, -1]}]
Status readFrames(const MapReader& root, Scene& s) {
  YAML::Node list;
  FEM_CLOTH_CHECK(root.list("frames", "a list of {name, vertex or grid_vertex}", list));
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string key = "frames[" + std::to_string(i) + "]";
    MapReader r(list[i], key, {"name", "vertex", "grid_vertex"});
    FEM_CLOTH_CHECK(r.check());
    SceneFrame f;
    FEM_CLOTH_CHECK(r.text("name", f.name));
    if (f.name.empty()) return Error{key + ".name is required"};
    if (r.has("vertex") == r.has("grid_vertex")) return Error{key + " needs one of vertex and grid_vertex"};
    if (r.has("vertex")) {
      int v = 0;
      FEM_CLOTH_CHECK(r.integer("vertex", v));
      f.select.vertices.push_back(v);
    } else {
      const YAML::Node n = r.child("grid_vertex");
      std::array<int, 2> rc{};
      if (!n.IsSequence() || n.size() != 2) return Error{r.where("grid_vertex") + " must be a [row, col] pair"};
      for (int j = 0; j < 2; ++j) FEM_CLOTH_CHECK(MapReader::toInteger(n[j], r.where("grid_vertex"), rc[j]));
      f.select.gridVertices.push_back(rc);
    }
    s.frames.push_back(f);
  }
  return Status::success();
}

Status readContact(const YAML::Node& node, Scene& s) {
  MapReader r(node, "contact",
              {"distance", "stiffness", "self_collision", "self_friction", "friction_velocity", "surface_stretch",
               "surface_tolerance"});
  FEM_CLOTH_CHECK(r.check());
  FEM_CLOTH_CHECK(r.number("distance", s.contact.distance));
  if (r.has("stiffness")) {
    const YAML::Node k = r.child("stiffness");
    if (k.IsScalar() && k.Scalar() == "auto") {
      s.contact.stiffness = 0.0;
    } else {
      FEM_CLOTH_CHECK(MapReader::toNumber(k, "contact.stiffness", s.contact.stiffness));
      if (!(s.contact.stiffness > 0.0)) {
        return Error{"contact.stiffness must be auto or positive (m/s^2), got " + describe(k)};
      }
    }
  }
  FEM_CLOTH_CHECK(r.boolean("self_collision", s.contact.selfCollision));
  // The friction of cloth on cloth: without self-contact it would do nothing, silently.
  if (r.has("self_friction") && !s.contact.selfCollision) {
    return Error{"contact.self_friction is the friction of cloth on cloth and needs contact.self_collision: "
                 "true (without self-contact it does nothing)"};
  }
  FEM_CLOTH_CHECK(r.number("self_friction", s.contact.selfFriction));
  FEM_CLOTH_CHECK(r.number("friction_velocity", s.contact.frictionVelocity));
  FEM_CLOTH_CHECK(r.number("surface_stretch", s.contact.surfaceStretch));
  if (r.has("surface_tolerance")) {
    const YAML::Node t = r.child("surface_tolerance");
    if (t.IsScalar() && t.Scalar() == "auto") {
      s.contact.surfaceTolerance = -1.0;
    } else {
      FEM_CLOTH_CHECK(MapReader::toNumber(t, "contact.surface_tolerance", s.contact.surfaceTolerance));
      if (!(s.contact.surfaceTolerance >= 0.0)) {
        return Error{"contact.surface_tolerance must be auto or at least 0 (m), got " + describe(t)};
      }
    }
  }
  return Status::success();
}

/// The fabric presets a materials folder holds (its <name>.yaml files), sorted.
std::vector<std::string> presetNames(const std::filesystem::path& folder) {
  std::vector<std::string> known;
  std::error_code ec;
  for (const auto& f : std::filesystem::directory_iterator(folder, ec)) {
    if (f.path().extension() == ".yaml") known.push_back(f.path().stem().string());
  }
  std::sort(known.begin(), known.end());
  return known;
}

/// A preset is a name (letters, digits, '_' and '-'), never a path: a scene from a bag, a batch
/// spec or a --set could otherwise make the reader open any file on the machine.
bool isPresetName(const std::string& value) {
  if (value.empty() || value.size() > 100) return false;
  return std::all_of(value.begin(), value.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
  });
}

/// material.preset: merges a fabric preset, <materials dir>/<name>.yaml (the package's
/// config/materials, or the folder $FEM_CLOTH_MATERIALS_DIR), under the scene's own keys: its
/// material keys where the scene has none (not its E and nu when the scene gives mu or lambda),
/// its bending stiffness and Poisson ratio likewise.
Expected<YAML::Node> withMaterialPreset(const YAML::Node& document) {
  // IsDefined() first: yaml-cpp throws when a missing key's node is asked anything else.
  if (!document.IsMap() || !document["material"].IsDefined() || !document["material"].IsMap() ||
      !document["material"]["preset"].IsDefined()) {
    return document;
  }
  const YAML::Node name = document["material"]["preset"];
  if (!name.IsScalar()) return Error{"material.preset must be a preset name, got " + describe(name)};
  const std::string value = name.Scalar();
  // The package's config/materials, found from the program's location (core/package_paths.h:
  // no source path compiled into this installed library), unless the environment names one.
  std::filesystem::path folder;
  if (const char* env = std::getenv("FEM_CLOTH_MATERIALS_DIR"); env != nullptr && *env != '\0') {
    folder = env;
  } else {
    const Expected<std::filesystem::path> found = findPackageFile("config/materials");
    if (!found) return Error{"material.preset '" + printableText(value, 100) + "': " + found.error() + " (or set $FEM_CLOTH_MATERIALS_DIR)"};
    folder = *found;
  }
  if (!isPresetName(value)) {
    return Error{"material.preset must be the name of a preset in " + folder.string() +
                 " (letters, digits, _ and -; not a path), got '" + printableText(value, 100) +
                 "' (known: " + commaList(presetNames(folder)) + ")"};
  }
  const std::filesystem::path path = folder / (value + ".yaml");
  std::error_code missing;
  if (!std::filesystem::is_regular_file(path, missing)) {
    return Error{"material.preset: no preset '" + value + "' (" + path.string() + "; known: " +
                 commaList(presetNames(folder)) + ")"};
  }
  // Bounded like the scene file itself: a preset naming /dev/zero or a binary is one error.
  Expected<std::string> text = readTextFile(path.string(), kMaxSceneFileBytes, "material preset file");
  if (!text) return Error{"material.preset: " + text.error()};
  YAML::Node preset;
  try {
    preset = YAML::Load(*text);
  } catch (const YAML::Exception& e) {
    return Error{"material.preset '" + value + "': malformed YAML in " + path.string() + ": " + e.msg};
  }
  const std::string where = "material.preset '" + value + "' (" + path.string() + ")";
  MapReader top(preset, where, {"material", "bending"});
  MapReader material(top.child("material"), where + ": material",
                     {"model", "youngs_modulus", "poisson_ratio", "mu", "lambda", "thickness", "density"});
  MapReader bending(top.child("bending"), where + ": bending", {"stiffness", "poisson_ratio"});
  for (const MapReader* r : {&top, &material, &bending}) FEM_CLOTH_CHECK(r->check());
  YAML::Node out = YAML::Clone(document);
  YAML::Node mine = out["material"];
  mine.remove("preset");
  const bool lame = mine["mu"].IsDefined() || mine["lambda"].IsDefined();
  for (const auto& kv : top.child("material")) {
    const std::string key = kv.first.as<std::string>();
    if (lame && (key == "youngs_modulus" || key == "poisson_ratio")) continue;
    if (!mine[key].IsDefined()) mine[key] = kv.second;
  }
  if (top.has("bending")) {
    if (!out["bending"].IsDefined() || out["bending"].IsNull()) out["bending"] = YAML::Node(YAML::NodeType::Map);
    YAML::Node bend = out["bending"];
    if (!bend.IsMap()) return document;  // parseScene reports the ill-typed bending key
    for (const auto& kv : top.child("bending")) {
      const std::string key = kv.first.as<std::string>();
      if (!bend[key].IsDefined()) bend[key] = kv.second;
    }
  }
  return out;
}

}  // namespace

namespace {

Status readMaterial(const MapReader& root, Scene& s) {
  MapReader mat(root.child("material"), "material",
                {"model", "youngs_modulus", "poisson_ratio", "mu", "lambda", "thickness",
                 "density"});
  FEM_CLOTH_CHECK(mat.check());
  FEM_CLOTH_CHECK(mat.text("model", s.materialModel));
  FEM_CLOTH_CHECK(mat.optionalNumber("youngs_modulus", s.youngsModulus));
  FEM_CLOTH_CHECK(mat.optionalNumber("poisson_ratio", s.poissonRatio));
  FEM_CLOTH_CHECK(mat.optionalNumber("mu", s.mu));
  FEM_CLOTH_CHECK(mat.optionalNumber("lambda", s.lambda));
  FEM_CLOTH_CHECK(mat.number("thickness", s.thickness));
  FEM_CLOTH_CHECK(mat.number("density", s.density));

  MapReader bend(root.child("bending"), "bending", {"model", "stiffness", "poisson_ratio"});
  FEM_CLOTH_CHECK(bend.check());
  FEM_CLOTH_CHECK(bend.named("model", bendingModelNames(), s.bendingModel));
  FEM_CLOTH_CHECK(bend.number("stiffness", s.bendingStiffness));
  FEM_CLOTH_CHECK(bend.number("poisson_ratio", s.bendingPoissonRatio));

  MapReader damp(root.child("damping"), "damping", {"mass", "stiffness"});
  FEM_CLOTH_CHECK(damp.check());
  FEM_CLOTH_CHECK(damp.number("mass", s.damping.massProportional));
  return damp.number("stiffness", s.damping.stiffnessProportional);
}

// `air:` given (a map, possibly empty: the defaults) declares the air model; absent or empty of
// value, there is none.
Status readAir(const MapReader& root, Scene& s) {
  if (!root.has("air") || root.child("air").IsNull()) return Status::success();
  MapReader air(root.child("air"), "air", {"density", "normal_drag", "tangential_drag", "wind"});
  FEM_CLOTH_CHECK(air.check());
  AirSettings a;
  FEM_CLOTH_CHECK(air.number("density", a.density));
  FEM_CLOTH_CHECK(air.number("normal_drag", a.normalDrag));
  FEM_CLOTH_CHECK(air.number("tangential_drag", a.tangentialDrag));
  FEM_CLOTH_CHECK(air.vector("wind", a.wind));
  s.air = a;
  return Status::success();
}

Status readPins(const MapReader& root, Scene& s) {
  YAML::Node pins;
  FEM_CLOTH_CHECK(root.list("pins", "a list", pins));
  for (std::size_t i = 0; i < pins.size(); ++i) {
    const std::string key = "pins[" + std::to_string(i) + "]";
    MapReader r(pins[i], key,
                {"vertices", "grid_vertices", "grid_edge", "offset", "targets", "velocity",
                 "trajectory", "release_at"});
    FEM_CLOTH_CHECK(r.check());
    ScenePin p;
    FEM_CLOTH_CHECK(readSelection(r, p.select));
    FEM_CLOTH_CHECK(r.vector("offset", p.offset));
    FEM_CLOTH_CHECK(r.vector("velocity", p.velocity));
    FEM_CLOTH_CHECK(r.number("release_at", p.releaseAt));
    FEM_CLOTH_CHECK(readTrajectory(r, p.trajectory));
    YAML::Node targets;
    FEM_CLOTH_CHECK(r.list("targets", "a list of positions", targets));
    for (std::size_t k = 0; k < targets.size(); ++k) {
      Eigen::Vector3d t;
      FEM_CLOTH_CHECK(MapReader::toVector(targets[k], key + ".targets[" + std::to_string(k) + "]", t));
      p.targets.push_back(t);
    }
    s.pins.push_back(p);
  }
  return Status::success();
}

Status readForces(const MapReader& root, Scene& s) {
  YAML::Node forces;
  FEM_CLOTH_CHECK(root.list("forces", "a list", forces));
  for (std::size_t i = 0; i < forces.size(); ++i) {
    const std::string key = "forces[" + std::to_string(i) + "]";
    MapReader r(forces[i], key, {"vertices", "grid_vertices", "grid_edge", "force", "start", "duration"});
    FEM_CLOTH_CHECK(r.check());
    SceneForce f;
    FEM_CLOTH_CHECK(readSelection(r, f.select));
    FEM_CLOTH_CHECK(r.vector("force", f.force));
    FEM_CLOTH_CHECK(r.number("start", f.start));
    FEM_CLOTH_CHECK(r.number("duration", f.duration));
    s.forces.push_back(f);
  }
  return Status::success();
}

Status readInitial(const MapReader& root, Scene& s) {
  MapReader init(root.child("initial"), "initial", {"positions", "velocity"});
  FEM_CLOTH_CHECK(init.check());
  FEM_CLOTH_CHECK(init.vector("velocity", s.initialVelocity));
  YAML::Node positions;
  FEM_CLOTH_CHECK(init.list("positions", "a list of {vertex, position}", positions));
  for (std::size_t i = 0; i < positions.size(); ++i) {
    const std::string key = "initial.positions[" + std::to_string(i) + "]";
    MapReader r(positions[i], key, {"vertex", "position"});
    FEM_CLOTH_CHECK(r.check());
    if (!r.has("vertex") || !r.has("position")) return Error{key + " needs vertex and position"};
    SceneInitialPosition p;
    FEM_CLOTH_CHECK(r.integer("vertex", p.vertex));
    FEM_CLOTH_CHECK(r.vector("position", p.position));
    s.initialPositions.push_back(p);
  }
  return Status::success();
}

Expected<Scene> readScene(const YAML::Node& doc, const std::string& sourcePath) {
  Scene s;
  s.sourcePath = sourcePath;
  MapReader root(doc, "",
                 {"name", "mesh", "material", "bending", "damping", "air", "gravity", "integrator",
                  "pins", "forces", "initial", "duration", "obstacles", "contact", "frames"});
  // Not describe(doc): a file that is no scene at all (a password file read as one long YAML
  // text) is not echoed into a log.
  if (!doc.IsMap()) {
    return Error{"scene must be a map of keys (mesh, material, ...), got " +
                 (doc.IsScalar() ? "a text of " + std::to_string(doc.Scalar().size()) + " characters: not a scene"
                                 : describe(doc))};
  }
  FEM_CLOTH_CHECK(root.check());
  FEM_CLOTH_CHECK(root.text("name", s.name));
  FEM_CLOTH_CHECK(readMesh(root.child("mesh"), s));
  FEM_CLOTH_CHECK(readMaterial(root, s));
  FEM_CLOTH_CHECK(readAir(root, s));
  FEM_CLOTH_CHECK(root.vector("gravity", s.gravity));
  // Two numbers are a planar scene's gravity; on a cloth in 3D they would leave out the vertical
  // one silently (gravity [0, 0] is weightless cloth, not the default).
  if (s.dim == 3 && root.has("gravity") && root.child("gravity").size() == 2) {
    return Error{"gravity has 2 numbers, the scene is 3D (mesh.dim 3): give [gx, gy, gz], got " +
                 describe(root.child("gravity"))};
  }
  FEM_CLOTH_CHECK(readIntegrator(root.child("integrator"), s));
  FEM_CLOTH_CHECK(root.number("duration", s.duration));
  FEM_CLOTH_CHECK(readPins(root, s));
  FEM_CLOTH_CHECK(readForces(root, s));
  FEM_CLOTH_CHECK(readObstacles(root, s));
  FEM_CLOTH_CHECK(readContact(root.child("contact"), s));
  FEM_CLOTH_CHECK(readFrames(root, s));
  FEM_CLOTH_CHECK(readInitial(root, s));
  if (Status v = validateScene(s); !v) return Error{v.error()};
  return s;
}

}  // namespace

Expected<Scene> parseScene(const YAML::Node& doc, const std::string& sourcePath) {
  // The readers check the kind of every node before converting it; should yaml-cpp still throw
  // on a document shaped in a way they did not foresee, that is bad input too, not a crash.
  try {
    Expected<YAML::Node> expanded = withMaterialPreset(doc);
    if (!expanded) return Error{expanded.error()};
    return readScene(*expanded, sourcePath);
  } catch (const YAML::Exception& e) {
    return Error{"scene: unexpected structure (" + e.msg + ")"};
  }
}

Status applySceneOverride(YAML::Node& document, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) {
    return Error{"override '" + assignment + "' must look like key.path=value"};
  }
  const std::string path = assignment.substr(0, eq);
  const std::string valueText = assignment.substr(eq + 1);
  YAML::Node value;
  try {
    value = YAML::Load(valueText);
  } catch (const YAML::Exception& e) {
    return Error{"override '" + assignment + "': value is not valid YAML (" + e.msg + ")"};
  }
  if (!value.IsDefined() || value.IsNull()) {
    return Error{"override '" + assignment + "' has no value"};
  }
  std::vector<std::string> parts;
  std::stringstream ss(path);
  for (std::string part; std::getline(ss, part, '.');) {
    if (part.empty()) return Error{"override key '" + path + "' has an empty component"};
    parts.push_back(part);
  }
  // Walk with fresh handles: yaml-cpp node assignment rebinds, so use a recursive lambda.
  std::function<Status(YAML::Node, std::size_t)> set = [&](YAML::Node node,
                                                          std::size_t i) -> Status {
    const std::string& part = parts[i];
    const bool last = i + 1 == parts.size();
    if (node.IsSequence()) {
      char* end = nullptr;
      const long index = std::strtol(part.c_str(), &end, 10);
      if (*end != '\0' || index < 0 || static_cast<std::size_t>(index) >= node.size()) {
        return Error{"override key '" + path + "': '" + part + "' is not an index of the list (" +
                     std::to_string(node.size()) + " entries)"};
      }
      if (last) {
        node[static_cast<std::size_t>(index)] = value;
        return Status::success();
      }
      return set(node[static_cast<std::size_t>(index)], i + 1);
    }
    if (!node.IsMap() && node.IsDefined() && !node.IsNull()) {
      return Error{"override key '" + path + "': " +
                   (i == 0 ? std::string("the scene") : "'" + parts[i - 1] + "'") + " is not a map"};
    }
    if (last) {
      node[part] = value;
      return Status::success();
    }
    YAML::Node child = node[part];
    if (!child.IsDefined() || child.IsNull()) {
      node[part] = YAML::Node(YAML::NodeType::Map);
    }
    return set(node[part], i + 1);
  };
  return set(document, 0);
}

Expected<YAML::Node> parseSceneText(const std::string& text, const std::string& where) {
  if (text.size() > kMaxSceneFileBytes) {
    return Error{where + ": " + std::to_string(text.size()) + " bytes, more than the " +
                 std::to_string(kMaxSceneFileBytes) + " bytes a scene may have"};
  }
  YAML::Node doc;
  try {
    // Every document, not the first: a second one (after ---) would be ignored silently.
    const std::vector<YAML::Node> documents = YAML::LoadAll(text);
    if (documents.size() > 1) {
      return Error{where + ": holds " + std::to_string(documents.size()) +
                   " YAML documents (separated by ---): a scene is one document"};
    }
    if (!documents.empty()) doc = documents.front();
  } catch (const YAML::Exception& e) {
    return Error{where + ": malformed YAML at line " + std::to_string(e.mark.line + 1) +
                 ", column " + std::to_string(e.mark.column + 1) + ": " + e.msg};
  }
  if (!doc.IsDefined() || doc.IsNull()) doc = YAML::Node(YAML::NodeType::Map);
  return doc;
}

Status applySceneOverrides(YAML::Node& document, const std::vector<std::string>& overrides) {
  for (const std::string& o : overrides) FEM_CLOTH_CHECK(applySceneOverride(document, o));
  std::vector<std::string> given;
  for (const std::string& o : overrides) {
    const std::string path = o.substr(0, o.find('='));
    if (path.rfind("integrator.", 0) == 0) {
      given.push_back(path.substr(std::string("integrator.").size()));
    } else if (path == "integrator") {  // integrator={name: bdf2, ...}: its keys
      const YAML::Node value = YAML::Load(o.substr(o.find('=') + 1));
      if (value.IsMap()) {
        for (const auto& kv : value) given.push_back(kv.first.Scalar());
      }
    }
  }
  return checkGivenIntegratorKeys(document, given, "--set integrator.");
}

Status checkGivenIntegratorKeys(const YAML::Node& document, const std::vector<std::string>& keys,
                                const std::string& source) {
  if (!document.IsMap()) return Status::success();
  std::string name = Scene{}.integrator;
  // Through const nodes: a missing key is then an undefined node, not an invalid one that throws.
  const YAML::Node& doc = document;
  const YAML::Node integrator = doc["integrator"];
  if (integrator.IsDefined() && integrator.IsMap()) {
    const YAML::Node chosen = integrator["name"];
    if (chosen.IsDefined() && chosen.IsScalar()) name = chosen.Scalar();
  }
  for (const std::string& key : keys) FEM_CLOTH_CHECK(checkIntegratorUsesKey(name, key, source + key));
  return Status::success();
}

Expected<YAML::Node> loadSceneDocument(const std::string& path,
                                       const std::vector<std::string>& overrides) {
  Expected<std::string> text = readTextFile(path, kMaxSceneFileBytes, "scene file");
  if (!text) return Error{text.error()};
  Expected<YAML::Node> parsed = parseSceneText(*text, path);
  if (!parsed) return Error{parsed.error()};
  YAML::Node doc = *parsed;
  FEM_CLOTH_CHECK(applySceneOverrides(doc, overrides));
  return doc;
}

Expected<Scene> loadScene(const std::string& path, const std::vector<std::string>& overrides,
                          YAML::Node* document) {
  Expected<YAML::Node> doc = loadSceneDocument(path, overrides);
  if (!doc) return Error{doc.error()};
  Expected<Scene> scene = parseScene(*doc, path);
  if (!scene) return Error{path + ": " + scene.error()};
  // reset, not =: a Node's assignment writes into the node it refers to.
  if (document != nullptr) document->reset(*doc);
  return scene;
}

std::string sceneDocumentToString(const YAML::Node& document) {
  YAML::Emitter out;
  out << document;
  return out.c_str();
}

}  // namespace fem_cloth
