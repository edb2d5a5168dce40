#include "fem_cloth/report/cases.h"

#include <cmath>
#include <iomanip>
#include <sstream>

#include "fem_cloth/core/mesh.h"
#include "fem_cloth/io/scene_yaml.h"

namespace fem_cloth::report {

namespace {

// A YAML list written on one line: [1, 2, 3].
template <class T>
YAML::Node flow(const std::vector<T>& values) {
  YAML::Node n(YAML::NodeType::Sequence);
  for (const T& v : values) n.push_back(v);
  n.SetStyle(YAML::EmitterStyle::Flow);
  return n;
}
YAML::Node vec(std::initializer_list<double> values) { return flow(std::vector<double>(values)); }

// A 1 m square, 1 kg/m^2 (density 2000 kg/m^3 x thickness 5e-4 m), cotton-like StVK with the
// hanging cloth's air drag: the common base of the extreme cases.
YAML::Node baseSheet(const std::string& name, int n, int dim) {
  YAML::Node doc;
  doc["name"] = name;
  doc["mesh"]["type"] = "grid";
  if (dim == 2) doc["mesh"]["dim"] = 2;
  doc["mesh"]["rows"] = n;
  doc["mesh"]["cols"] = n;
  doc["mesh"]["width"] = 1.0;
  doc["mesh"]["height"] = 1.0;
  doc["material"]["model"] = "stvk";
  doc["material"]["youngs_modulus"] = 2.0e7;
  doc["material"]["poisson_ratio"] = 0.3;
  doc["material"]["thickness"] = 5.0e-4;
  doc["material"]["density"] = 2000.0;
  doc["damping"]["mass"] = 0.1;
  doc["gravity"] = dim == 2 ? vec({0.0, 0.0}) : vec({0.0, 0.0, -9.81});
  doc["integrator"]["name"] = "backward_euler";
  doc["integrator"]["dt"] = 0.01;
  // 0.1 s: a whole number of every step of the matrix (1e-4, 1e-3, 1e-2 and 1/30 s).
  doc["duration"] = 0.1;
  return doc;
}

YAML::Node gridVertex(int row, int col) {
  YAML::Node list(YAML::NodeType::Sequence);
  list.push_back(flow(std::vector<int>{row, col}));
  return list;
}

// The opposite corner is pulled along the diagonal, away from the held corner, by five cloth
// sizes (5 m) in 0.1 s, then let go.
YAML::Node pullCorner(int n) {
  YAML::Node doc = baseSheet("pull_corner", n, 3);
  YAML::Node held;
  held["grid_vertices"] = gridVertex(0, 0);
  YAML::Node pulled;
  pulled["grid_vertices"] = gridVertex(-1, -1);
  const double speed = 5.0 / 0.1 / std::sqrt(2.0);  // m/s per axis: 50 m/s along the diagonal
  pulled["velocity"] = vec({speed, speed, 0.0});
  pulled["release_at"] = 0.1;
  doc["pins"].push_back(held);
  doc["pins"].push_back(pulled);
  doc["duration"] = 0.2;
  return doc;
}

// Every boundary vertex moves straight to the centre of the sheet, arriving at t = 0.1 s (zero
// area: the whole boundary at one point), and is released there.
YAML::Node squash(int n) {
  YAML::Node doc = baseSheet("squash", n, 2);
  const double h = 1.0 / (n - 1);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) {
      if (r != 0 && r != n - 1 && c != 0 && c != n - 1) continue;
      YAML::Node pin;
      pin["vertices"] = flow(std::vector<int>{r * n + c});
      pin["velocity"] = vec({(0.5 - c * h) / 0.1, (0.5 - r * h) / 0.1});
      pin["release_at"] = 0.1;
      doc["pins"].push_back(pin);
    }
  }
  doc["duration"] = 0.2;
  return doc;
}

// The left half of the sheet (x < 0.5) starts mirrored about x = 0.5, on top of the right half:
// every element of that half is inverted (J = -1) while none is strained in size. Free, no
// gravity: an inversion-aware material unfolds it.
YAML::Node inverted(int n) {
  YAML::Node doc = baseSheet("inverted", n, 2);
  const double h = 1.0 / (n - 1);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; 2 * c < n - 1; ++c) {
      YAML::Node p;
      p["vertex"] = r * n + c;
      p["position"] = vec({1.0 - c * h, r * h});
      doc["initial"]["positions"].push_back(p);
    }
  }
  return doc;
}

// The hanging cloth on an explicit copy of the grid in which two interior vertices are moved to
// within 1e-5 mesh spacings of the edge opposite them in one of their triangles: that triangle
// becomes a sliver (quality ~1e-5) in the rest mesh itself, and so does a neighbour when that
// edge lies on a grid line (three slivers in all). Every triangle stays valid (the vertex stays
// inside its convex star), so the mesh passes validation with min_quality lowered to 1e-8.
Expected<YAML::Node> degenerate(int n) {
  GridSpec spec;
  spec.rows = spec.cols = n;
  Expected<Mesh> grid = makeGrid(spec);
  if (!grid) return Error{grid.error()};
  Mesh mesh = std::move(grid).value();
  const double h = 1.0 / (n - 1);
  for (const Index v : {static_cast<Index>((n / 4) * n + n / 4), static_cast<Index>((n / 2) * n + n / 2 + 1)}) {
    for (const Triangle& t : mesh.triangles) {
      int k = 0;
      while (k < 3 && t[k] != v) ++k;
      if (k == 3) continue;
      const Eigen::Vector3d a = mesh.restPositions.segment<3>(3 * t[(k + 1) % 3]);
      const Eigen::Vector3d b = mesh.restPositions.segment<3>(3 * t[(k + 2) % 3]);
      const Eigen::Vector3d p = mesh.restPositions.segment<3>(3 * v);
      const Eigen::Vector3d mid = 0.5 * (a + b);
      mesh.restPositions.segment<3>(3 * v) = mid + 1e-5 * h * (p - mid).normalized();
      break;
    }
  }
  YAML::Node doc = baseSheet("degenerate", n, 3);
  doc["mesh"] = YAML::Node();
  doc["mesh"]["type"] = "explicit";
  doc["mesh"]["min_quality"] = 1e-8;
  for (Index i = 0; i < mesh.numVertices(); ++i) {
    const Eigen::Vector3d x = mesh.restPositions.segment<3>(3 * i);
    doc["mesh"]["vertices"].push_back(vec({x[0], x[1], x[2]}));
  }
  for (const Triangle& t : mesh.triangles) {
    doc["mesh"]["triangles"].push_back(flow(std::vector<Index>(t.begin(), t.end())));
  }
  YAML::Node pins;
  pins["vertices"] = flow(std::vector<int>{0, n - 1});
  doc["pins"].push_back(pins);
  return doc;
}

// Hanging from one corner that is yanked out of plane at 100 m/s from the start.
YAML::Node whip(int n) {
  YAML::Node doc = baseSheet("whip", n, 3);
  YAML::Node pin;
  pin["grid_vertices"] = gridVertex(0, 0);
  pin["velocity"] = vec({0.0, 0.0, 100.0});
  doc["pins"].push_back(pin);
  return doc;
}

// Thrown flat at a floor (a plane with friction 0.4, contact distance 1 mm) from 5 cm above
// it at 10 m/s down and 2 m/s along it: the cloth reaches the floor within 5 ms, i.e. inside
// the first step at every dt but the smallest, and must stop on it without passing through.
YAML::Node slam(int n) {
  YAML::Node doc = baseSheet("slam", n, 3);
  doc["mesh"]["origin"] = vec({0.0, 0.0, 0.05});
  doc["initial"]["velocity"] = vec({2.0, 0.0, -10.0});
  YAML::Node floor;
  floor["name"] = "floor";
  floor["type"] = "plane";
  floor["point"] = vec({0.0, 0.0, 0.0});
  floor["normal"] = vec({0.0, 0.0, 1.0});
  floor["friction"] = 0.4;
  doc["obstacles"].push_back(floor);
  doc["contact"]["distance"] = 1e-3;
  return doc;
}

// The sudden-load strip of issue 11 (cases.h, StripCase): 4 N per vertex along the strip on its
// last column, 2 N on its two corners (the consistent nodal loads of a uniform traction).
YAML::Node strip() {
  using S = StripCase;
  YAML::Node doc = baseSheet("strip", 5, 3);
  doc["mesh"]["rows"] = S::rows;
  doc["mesh"]["cols"] = S::cols;
  doc["mesh"]["width"] = S::length;
  doc["mesh"]["height"] = S::width;
  doc["material"]["density"] = 0.2 / S::thickness;
  doc["damping"]["mass"] = 30.0;
  doc["gravity"] = vec({0.0, 0.0, 0.0});
  YAML::Node pin;
  pin["grid_edge"] = "first_col";
  doc["pins"].push_back(pin);
  const double perVertex = S::force / (S::rows - 1);
  YAML::Node inner, corners;
  for (int r = 1; r + 1 < S::rows; ++r) inner["grid_vertices"].push_back(flow(std::vector<int>{r, -1}));
  inner["force"] = vec({perVertex, 0.0, 0.0});
  corners["grid_vertices"].push_back(flow(std::vector<int>{0, -1}));
  corners["grid_vertices"].push_back(flow(std::vector<int>{-1, -1}));
  corners["force"] = vec({0.5 * perVertex, 0.0, 0.0});
  doc["forces"].push_back(inner);
  doc["forces"].push_back(corners);
  doc["duration"] = 0.5;  // a whole number of every step of the matrix
  return doc;
}

}  // namespace

std::string setting(const std::string& key, double value) {
  std::ostringstream s;
  s << key << '=' << std::setprecision(17) << value;
  return s.str();
}

Expected<YAML::Node> withOverrides(const YAML::Node& document,
                                   const std::vector<std::string>& overrides) {
  YAML::Node copy = YAML::Clone(document);
  for (const std::string& o : overrides) {
    if (Status s = applySceneOverride(copy, o); !s) return Error{s.error()};
  }
  return copy;
}

std::vector<Variant> workPrecisionVariants(const std::vector<std::string>& integrators, bool small) {
  std::vector<Variant> out;
  for (const std::string& name : integrators) {
    auto add = [&](const std::string& label, std::vector<std::string> overrides) {
      overrides.insert(overrides.begin(), "integrator.name=" + name);
      out.push_back(Variant{name, label, overrides});
    };
    if (name == "symplectic_euler") {
      for (double safety : small ? std::vector<double>{0.5} : std::vector<double>{0.5, 0.25, 0.125}) {
        add(name + " cfl " + numberText(safety), {setting("integrator.cfl_safety", safety)});
      }
    } else if (name == "backward_euler" || name == "bdf2") {
      // Acceptance test (a): the default error ratio (0.1 of the step's truncation error), and a
      // looser one for backward Euler, a tighter one for BDF2 (whose own error is smaller).
      std::vector<double> ratios = {0.1};
      if (!small) ratios.push_back(name == "bdf2" ? 1e-3 : 1.0);
      for (double ratio : ratios) {
        add(name + " ratio " + numberText(ratio), {setting("integrator.error_ratio", ratio)});
      }
    } else if (name == "projective_dynamics") {
      // Around its default of 10 local/global iterations, and the fast scene's setting
      // (config/hanging_cloth_fast.yaml: 7 iterations with Chebyshev acceleration, rho 0.9).
      for (int it : small ? std::vector<int>{10} : std::vector<int>{5, 10, 20}) {
        add(name + " " + std::to_string(it) + " it", {"integrator.iterations=" + std::to_string(it)});
      }
      if (!small) add(name + " 7 it rho 0.9", {"integrator.iterations=7", "integrator.chebyshev_rho=0.9"});
    } else {
      std::vector<int> iterations = small ? std::vector<int>{4} : std::vector<int>{4, 16, 64};
      if (name == "xpbd" && !small) iterations.insert(iterations.begin(), 1);
      for (int it : iterations) {
        add(name + " " + std::to_string(it) + " it", {"integrator.iterations=" + std::to_string(it)});
      }
    }
  }
  return out;
}

namespace {

// test/core/test_convergence.cpp's smooth problem: a free planar 4 x 4 StVK sheet, membrane
// moduli mu = lambda = 1 N/m, 1 kg/m^2, no gravity, no damping, released from rest at
// x = X + a (sin(pi X) cos(pi Y / 2), sin(pi Y) cos(pi X / 2)), a = 0.08 m.
YAML::Node smoothSheet() {
  YAML::Node doc;
  doc["name"] = "smooth";
  doc["mesh"]["type"] = "grid";
  doc["mesh"]["dim"] = 2;
  doc["mesh"]["rows"] = 4;
  doc["mesh"]["cols"] = 4;
  doc["material"]["model"] = "stvk";
  doc["material"]["mu"] = 1000.0;
  doc["material"]["lambda"] = 1000.0;
  doc["material"]["thickness"] = 1e-3;
  doc["material"]["density"] = 1000.0;
  doc["gravity"] = vec({0.0, 0.0});
  doc["integrator"]["name"] = "backward_euler";
  doc["integrator"]["dt"] = 0.0125;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      const double X = c / 3.0, Y = r / 3.0, a = 0.08;
      YAML::Node p;
      p["vertex"] = r * 4 + c;
      p["position"] = vec({X + a * std::sin(M_PI * X) * std::cos(0.5 * M_PI * Y),
                           Y + a * std::sin(M_PI * Y) * std::cos(0.5 * M_PI * X)});
      doc["initial"]["positions"].push_back(p);
    }
  }
  doc["duration"] = 0.25;
  return doc;
}

}  // namespace

Expected<std::vector<AccuracyScene>> accuracyScenes(const std::string& configDir,
                                                    std::shared_ptr<const Recording> recording, bool small) {
  std::vector<AccuracyScene> scenes;
  const int n = small ? 9 : 17;
  const std::vector<std::string> size = {"mesh.rows=" + std::to_string(n),
                                         "mesh.cols=" + std::to_string(n)};
  const std::vector<double> dts = small ? std::vector<double>{1.0 / 30, 1.0 / 60, 1.0 / 120}
                                        : std::vector<double>{1.0 / 30, 1.0 / 60, 1.0 / 120,
                                                              1.0 / 240, 1.0 / 480};
  auto fromFile = [&](const std::string& name, const std::string& file,
                      std::vector<std::string> overrides, double duration,
                      const std::string& description) -> Status {
    overrides.insert(overrides.end(), size.begin(), size.end());
    Expected<YAML::Node> doc = loadSceneDocument(configDir + "/" + file, overrides);
    if (!doc) return Error{doc.error()};
    AccuracyScene s;
    s.name = name;
    s.description = description;
    s.document = *doc;
    s.document["name"] = name;
    s.duration = small ? 0.2 : duration;
    s.sampleInterval = 1.0 / 30.0;
    s.dts = dts;
    s.referenceDt = s.dts.back() / 8.0;
    scenes.push_back(std::move(s));
    return Status::success();
  };
  const std::string grid = std::to_string(n) + " x " + std::to_string(n);
  if (Status s = fromFile("hanging_cloth", "hanging_cloth.yaml", {}, 0.3,
                          "config/hanging_cloth.yaml at " + grid + ": cotton-like StVK (1e4 N/m) "
                          "falling from flat, pinned at two corners, until folds form");
      !s) {
    return Error{s.error()};
  }
  if (Status s = fromFile("stiff_cloth", "stiff_cloth.yaml", {}, 0.2,
                          "config/stiff_cloth.yaml at " + grid + ": 100x stiffer (1e6 N/m), "
                          "nu = 0.45, undamped");
      !s) {
    return Error{s.error()};
  }
  if (Status s = fromFile("hanging_arap", "hanging_cloth.yaml", {"material.model=arap"}, 0.3,
                          "the hanging cloth with the ARAP material (for integrators that need it)");
      !s) {
    return Error{s.error()};
  }
  if (small) return scenes;
  if (Status s = fromFile("stiff_arap", "stiff_cloth.yaml", {"material.model=arap"}, 0.2,
                          "the stiff cloth with the ARAP material (for integrators that need it)");
      !s) {
    return Error{s.error()};
  }
  if (recording != nullptr) {
    const std::string& bag = recording->path();
    AccuracyScene s;
    s.name = "grasp";
    s.description = "a recorded grasp-and-lift (" + bag.substr(bag.find_last_of('/') + 1) +
                    "): commands and gripper frames re-applied";
    s.recording = recording;
    Expected<YAML::Node> doc = recording->scene();
    if (!doc) return Error{doc.error()};
    s.document = *doc;
    s.document["name"] = "grasp";
    s.commandsBag = bag;
    // The commands are stamped on the recording's steps (0.01 s): every tested dt divides it.
    s.commandGrid = s.document["integrator"]["dt"].as<double>(0.01);
    s.sampleInterval = 0.04;
    s.dts = {0.04, 0.02, 0.01, 0.005, 0.0025};
    s.referenceDt = s.dts.back() / 8.0;
    const double recorded = recording->recordedDuration();
    s.duration = std::floor(recorded / s.sampleInterval + 1e-6) * s.sampleInterval;
    scenes.push_back(std::move(s));
  }
  if (Status s = fromFile("hanging_long", "hanging_cloth.yaml", {}, 1.0,
                          "the hanging cloth over 1 s: after the cloth folds, positions are "
                          "sensitive to any perturbation");
      !s) {
    return Error{s.error()};
  }
  scenes.back().dts = {1.0 / 60, 1.0 / 240};
  scenes.back().defaultSettingsOnly = true;
  AccuracyScene smooth;
  smooth.name = "smooth";
  smooth.description = "test_convergence's free planar 4 x 4 sheet (1 N/m) released from a smooth "
                       "stretch: every mode resolved";
  smooth.document = smoothSheet();
  smooth.duration = 0.25;
  smooth.sampleInterval = 0.0125;
  smooth.dts = {1.0 / 80, 1.0 / 160, 1.0 / 320, 1.0 / 640};
  smooth.referenceDt = smooth.dts.back() / 8.0;
  scenes.push_back(std::move(smooth));
  return scenes;
}

const std::vector<Stiffness>& stiffnessLevels() {
  static const std::vector<Stiffness> levels = {
      {"cotton", 2.0e7, 0.3}, {"100x", 2.0e9, 0.45}, {"1000x", 2.0e10, 0.49}};
  return levels;
}

const std::vector<double>& stabilityDts() {
  static const std::vector<double> dts = {1e-4, 1e-3, 1e-2, 1.0 / 30.0};
  return dts;
}

const std::vector<std::string>& extremeCaseNames() {
  static const std::vector<std::string> names = {"pull_corner", "squash", "inverted",
                                                 "degenerate", "whip", "slam", "strip"};
  return names;
}

std::string extremeCaseDescription(const std::string& name) {
  if (name == "pull_corner") return "a corner pulled 5 m (5 cloth sizes) in 0.1 s, then let go";
  if (name == "squash") return "planar sheet, boundary driven to its centre in 0.1 s (zero area), then let go";
  if (name == "inverted") return "planar sheet, left half starts folded onto the right half (J = -1)";
  if (name == "degenerate") return "hanging cloth whose rest mesh has three slivers (quality ~1e-5)";
  if (name == "whip") return "cloth hanging from one corner yanked at 100 m/s";
  if (name == "slam") return "cloth thrown flat at a floor (contact, friction 0.4) at 10 m/s";
  if (name == "strip") return "strip 0.4 x 0.1 m pinned at one end, 20 N suddenly on the other";
  return name;
}

Expected<YAML::Node> extremeCase(const std::string& name, int n) {
  if (n < 5 || n % 2 == 0) return Error{"extreme cases need an odd grid size >= 5, got " + std::to_string(n)};
  if (name == "pull_corner") return pullCorner(n);
  if (name == "squash") return squash(n);
  if (name == "inverted") return inverted(n);
  if (name == "degenerate") return degenerate(n);
  if (name == "whip") return whip(n);
  if (name == "slam") return slam(n);
  if (name == "strip") return strip();
  return Error{"unknown extreme case '" + name + "'"};
}

Expected<YAML::Node> cellScene(const Cell& cell, int n) {
  Expected<YAML::Node> base = extremeCase(cell.caseName, n);
  if (!base) return base;
  const Stiffness* level = nullptr;
  for (const Stiffness& s : stiffnessLevels()) {
    if (s.name == cell.stiffness) level = &s;
  }
  if (level == nullptr) return Error{"unknown stiffness level '" + cell.stiffness + "'"};
  return withOverrides(*base, {"material.model=" + cell.material,
                               setting("material.youngs_modulus", level->youngsModulus),
                               setting("material.poisson_ratio", level->poissonRatio),
                               "integrator.name=" + cell.integrator,
                               setting("integrator.dt", cell.dt)});
}

}  // namespace fem_cloth::report
