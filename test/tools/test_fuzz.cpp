// Fuzzing the input boundary (issue 11, item 6): scenes and bags mutated at random (lines and
// keys deleted or repeated, values replaced by extreme ones or by nodes of another type, text
// truncated, bytes flipped) are fed to the built tools, each run killed after a time bound.
// Every run must end by itself with a status the tool documents (fem_cloth_sim: 0, 2 or 3;
// fem_cloth_bagdiff: 0, 1 or 2; bag_report.py: 0 or 2) and, when it refuses, with one line
// naming the problem; never a signal, a hang or a traceback.
//
// The seed is fixed (FEM_CLOTH_FUZZ_SEED overrides it) and printed, so a failure is repeated
// by running the test again; a failing input is kept (its path is printed) and should be added
// to test/data/fuzz/, whose inputs (ones that crashed the tools before) run first, every time.
// FEM_CLOTH_FUZZ_SIM and FEM_CLOTH_FUZZ_BAGDIFF point the test at other builds of the tools.
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <std_msgs/String.h>
#include <tf2_msgs/TFMessage.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>

#include "../run_program.h"
#include "fem_cloth/ClothState.h"
#include "fem_cloth/ForceCommand.h"
#include "fem_cloth/GraspCommand.h"
#include "fem_cloth/ObstacleCommand.h"
#include "fem_cloth/PinCommand.h"
#include "fem_cloth/SetCommand.h"

namespace fs = std::filesystem;
using fem_cloth::test::ProgramResult;
using fem_cloth::test::TempDir;

namespace {

std::string fromEnvironment(const char* name, const std::string& fallback) {
  const char* value = std::getenv(name);
  return value != nullptr && *value != '\0' ? value : fallback;
}

const std::string kSim = fromEnvironment("FEM_CLOTH_FUZZ_SIM", FEM_CLOTH_SIM_EXE);
const std::string kBagdiff = fromEnvironment("FEM_CLOTH_FUZZ_BAGDIFF", FEM_CLOTH_BAGDIFF);
const std::string kBagReport = FEM_CLOTH_BAG_REPORT;
const std::string kRegressions = std::string(FEM_CLOTH_SOURCE_DIR) + "/test/data/fuzz";
// Generous: a run takes a tenth of a second; the bound is for a machine under heavy load.
constexpr int kTimeBound = 60;

const std::uint64_t kSeed = std::stoull(fromEnvironment("FEM_CLOTH_FUZZ_SEED", "20260611"));
// How many times the usual number of cases each generator makes (thousands on demand).
const int kCaseFactor = std::max(1, std::stoi(fromEnvironment("FEM_CLOTH_FUZZ_CASES", "1")));
// Bytes of /etc/passwd no refusal may echo (issue 31: a preset naming it echoed its first bytes).
const char* kPasswdBytes = "root:x:0:0";

const TempDir& scratch() {
  static const TempDir dir("fem_cloth_test_fuzz");
  return dir;
}

// splitmix64: the same sequence on every platform (std's distributions are not specified).
class Random {
 public:
  explicit Random(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
  std::size_t below(std::size_t n) { return n == 0 ? 0 : static_cast<std::size_t>(next() % n); }
  template <class T>
  const T& pick(const std::vector<T>& items) { return items[below(items.size())]; }

 private:
  std::uint64_t state_;
};

// Small scenes covering the readers: a grid with pins, forces and trajectories (symplectic
// Euler), obstacles and self-collision (backward Euler), an OBJ mesh (XPBD), an explicit planar
// mesh (BDF2), projective dynamics. Each runs a few steps in well under a second.
const std::vector<std::string> kScenes = {
    R"(name: grid
mesh: {type: grid, rows: 5, cols: 5, width: 0.4, height: 0.4, plane: xz, origin: [0, 0, 1]}
material: {model: stvk, youngs_modulus: 2.0e6, poisson_ratio: 0.3, thickness: 5.0e-4, density: 2000}
bending: {model: quadratic, stiffness: 1.0e-5}
damping: {mass: 0.5, stiffness: 0.001}
gravity: [0, 0, -9.81]
integrator: {name: symplectic_euler, dt: 0.01, auto_substep: true, cfl_safety: 0.5, max_retries: 2}
pins:
  - grid_vertices: [[-1, 0], [-1, -1]]
    trajectory:
      - {time: 0.0, offset: [0, 0, 0]}
      - {time: 0.02, offset: [0, 0.01, 0]}
    release_at: 0.03
  - vertices: [12]
    velocity: [0, 0.1, 0]
forces:
  - {grid_edge: first_row, force: [0, 0.01, 0], start: 0.01, duration: 0.02}
initial:
  velocity: [0, 0.1, 0]
  positions: [{vertex: 6, position: [0.1, 0.01, 0.9]}]
duration: 0.04
)",
    R"(name: contact
mesh: {type: grid, rows: 5, cols: 5, width: 0.4, height: 0.4, origin: [-0.2, -0.2, 0.3]}
material: {model: neo_hookean, mu: 1.0e6, lambda: 1.0e6, thickness: 5.0e-4, density: 400}
damping: {mass: 0.1}
integrator: {name: backward_euler, dt: 0.01, max_newton_iterations: 20, newton_tolerance: 1.0e-3, linear_solver: auto}
obstacles:
  - {name: ball, type: sphere, center: [0, 0, 0.1], radius: 0.1, friction: 0.3}
  - {name: table, type: box, center: [0, 0, -0.5], size: [1, 1, 1], orientation: [0, 0, 0.1]}
  - {name: floor, type: plane, point: [0, 0, -2], normal: [0, 0, 1], velocity: [0, 0, 0.1]}
  - {name: rod, type: capsule, center: [0.5, 0.5, 0.5], radius: 0.02, length: 0.2,
     trajectory: [{time: 0, offset: [0, 0, 0]}, {time: 0.1, offset: [0, 0, 0.1]}]}
contact: {distance: 0.002, stiffness: auto, self_collision: true, self_friction: 0.2, friction_velocity: 0.001}
duration: 0.03
)",
    R"(name: obj
mesh: {type: obj, file: mesh.obj, dim: 3, min_quality: 1.0e-4}
material: {model: corotational, youngs_modulus: 1.0e6, poisson_ratio: 0.25}
integrator: {name: xpbd, dt: 0.01, iterations: 5, substeps: 2}
pins: [{vertices: [0, 1]}]
duration: 0.03
)",
    R"(name: planar
mesh:
  type: explicit
  dim: 2
  vertices: [[0, 0], [1, 0], [0, 1], [1, 1]]
  triangles: [[0, 1, 2], [1, 3, 2]]
material: {model: stable_neo_hookean, youngs_modulus: 1.0e4, poisson_ratio: 0.4, thickness: 1.0e-3}
gravity: [0, -9.81]
integrator: {name: bdf2, dt: 0.01, max_backtracks: 10, linear_solver: ldlt}
pins: [{vertices: [0], targets: [[0, 0, 0]]}]
initial: {positions: [{vertex: 3, position: [1.1, 1.0, 0]}]}
duration: 0.03
)",
    R"(name: pd
mesh: {type: grid, rows: 4, cols: 4, width: 0.3, height: 0.3}
material: {model: arap, youngs_modulus: 2.0e6, poisson_ratio: 0.3}
bending: {model: quadratic, stiffness: 1.0e-5}
integrator: {name: projective_dynamics, dt: 0.01, iterations: 5, chebyshev_rho: 0.9}
pins: [{grid_edge: first_row}]
duration: 0.03
)"};

const char* kObj = "v 0 0 0\nv 0.2 0 0\nv 0 0.2 0\nv 0.2 0.2 0\nv 0.1 0.3 0.05\nf 1 2 4 3\nf 3/1 4/2/3 5//1\n";

// Values a careless or hostile scene may hold: in place of a value...
const std::vector<std::string> kExtremeValues = {
    "0", "-1", "1", "2", "1e300", "-1e300", "1e-300", ".nan", ".inf", "-.inf", "2147483648",
    "4294967296", "1e9", "1e18", "-0", "0.5", "''", "x", "~", "true", "0x7fffffff", "1e999",
    "all", "first_row", "obj", "explicit", "'../../x'", "/dev/zero", "/", "-2147483649"};
// ... and in place of any node.
const std::vector<std::string> kStructures = {
    "~", "[]", "{}", "[1, 2, 3]", "[1e300, 0, 0]", "[.nan, 0, 0]", "{a: 1}", "[[0, 0]]",
    "[0, -1]", "[-1, -1]", "{? [a, b] : 1}", "{? {x: 1} : 2}", "[a, [b, [c]]]", "[{}]", "[~]"};
const std::vector<std::string> kStrangeLines = {
    "? [a, b]\n: 1", "&a [*a]", "!!binary AAAA", "{", "- - -", "mesh: ~", "\t", "'", "? ",
    "*undefined", "key: &x {a: *x}", "mesh: {type: obj, file: /dev/zero}", "name: ../x"};

std::vector<std::string> splitLines(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream s(text);
  for (std::string line; std::getline(s, line);) out.push_back(line);
  return out;
}

std::string joinLines(const std::vector<std::string>& lines) {
  std::string out;
  for (const std::string& l : lines) out += l + "\n";
  return out;
}

using Setter = std::function<void(const YAML::Node&)>;

// Every node of a YAML tree, depth first, with a way to replace it in its parent (and, for the
// scalars, in `leaves` too) or to remove its key.
void collect(YAML::Node node, std::vector<Setter>& setters, std::vector<std::function<void()>>& removers,
             std::vector<Setter>& leaves, int depth = 0) {
  if (depth > 20) return;
  auto add = [&](const Setter& set, const YAML::Node& child) {
    setters.push_back(set);
    if (child.IsScalar()) leaves.push_back(set);
    collect(child, setters, removers, leaves, depth + 1);
  };
  if (node.IsMap()) {
    for (auto kv : node) {
      const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : std::string();
      if (key.empty()) continue;
      YAML::Node parent = node;
      removers.push_back([parent, key]() mutable { parent.remove(key); });
      add([parent, key](const YAML::Node& v) mutable { parent[key] = v; }, kv.second);
    }
  } else if (node.IsSequence()) {
    for (std::size_t i = 0; i < node.size(); ++i) {
      YAML::Node parent = node;
      add([parent, i](const YAML::Node& v) mutable { parent[i] = v; }, node[i]);
    }
  }
}

// One mutation of a scene's text; `what` says which, for the report of a failure.
std::string mutateScene(const std::string& text, Random& random, std::string& what) {
  std::vector<std::string> lines = splitLines(text);
  switch (random.below(8)) {
    case 0: {
      const std::size_t k = random.below(lines.size());
      what += "delete line " + std::to_string(k + 1) + "; ";
      lines.erase(lines.begin() + static_cast<long>(k));
      return joinLines(lines);
    }
    case 1: {
      const std::size_t k = random.below(lines.size());
      what += "repeat line " + std::to_string(k + 1) + "; ";
      lines.insert(lines.begin() + static_cast<long>(k), lines[k]);
      return joinLines(lines);
    }
    case 2: {
      // At the top half of the time: a key of the scene; else anywhere (mostly breaking it).
      const std::size_t k = random.below(2) == 0 ? 0 : random.below(lines.size() + 1);
      const std::string& line = random.pick(kStrangeLines);
      what += "insert '" + line + "' at line " + std::to_string(k + 1) + "; ";
      lines.insert(lines.begin() + static_cast<long>(k), line);
      return joinLines(lines);
    }
    case 3: {
      const std::size_t cut = random.below(text.size());
      what += "truncate at byte " + std::to_string(cut) + "; ";
      return text.substr(0, cut);
    }
    case 4: {
      std::string out = text;
      const std::size_t at = random.below(out.size());
      const char bits = static_cast<char>(1 + random.below(255));
      what += "flip byte " + std::to_string(at) + "; ";
      out[at] = static_cast<char>(out[at] ^ bits);
      return out;
    }
    default: break;
  }
  // Tree mutations (on text that is still YAML).
  YAML::Node doc;
  try {
    doc = YAML::Load(text);
  } catch (const YAML::Exception&) {
    what += "(not YAML any more); ";
    return text;
  }
  std::vector<std::function<void(const YAML::Node&)>> setters, leafSetters;
  std::vector<std::function<void()>> removers;
  collect(doc, setters, removers, leafSetters);
  if (setters.empty()) return text;
  const std::size_t kind = random.below(3);
  if (kind == 0 && !removers.empty()) {
    const std::size_t k = random.below(removers.size());
    what += "remove key #" + std::to_string(k) + "; ";
    removers[k]();
  } else if (kind == 1 && !leafSetters.empty()) {
    const std::size_t k = random.below(leafSetters.size());
    const std::string& value = random.pick(kExtremeValues);
    what += "set value #" + std::to_string(k) + " to " + value + "; ";
    leafSetters[k](YAML::Load(value));
  } else {
    const std::size_t k = random.below(setters.size());
    const std::string& value = random.pick(kStructures);
    what += "set node #" + std::to_string(k) + " to " + value + "; ";
    setters[k](YAML::Load(value));
  }
  YAML::Emitter out;
  out << doc;
  return std::string(out.c_str()) + "\n";
}

// One mutation of a bag's bytes.
std::string mutateBag(const std::string& bytes, Random& random, std::string& what) {
  std::string out = bytes;
  switch (random.below(5)) {
    case 0: {
      const std::size_t cut = random.below(out.size());
      what += "truncate at byte " + std::to_string(cut) + "; ";
      out.resize(cut);
      break;
    }
    case 1:
    case 2: {
      const std::size_t flips = 1 + random.below(8);
      what += "flip " + std::to_string(flips) + " bytes at";
      for (std::size_t i = 0; i < flips; ++i) {
        const std::size_t at = random.below(out.size());
        what += " " + std::to_string(at);
        out[at] = static_cast<char>(out[at] ^ static_cast<char>(1 + random.below(255)));
      }
      what += "; ";
      break;
    }
    case 3: {
      const std::size_t at = random.below(out.size()), n = 1 + random.below(64);
      what += "zero " + std::to_string(n) + " bytes at " + std::to_string(at) + "; ";
      for (std::size_t i = at; i < std::min(out.size(), at + n); ++i) out[i] = '\0';
      break;
    }
    default: {
      // A length field set to a huge value: 0xff bytes over four of the bytes.
      const std::size_t at = random.below(out.size());
      what += "0xffffffff at " + std::to_string(at) + "; ";
      for (std::size_t i = at; i < std::min(out.size(), at + 4); ++i) out[i] = '\xff';
    }
  }
  return out;
}

std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void writeBytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

int failures = 0;

// Keeps the input of a failed case (outside the scratch folder, which goes) and says how to
// repeat it.
void report(const std::string& tool, const std::string& input, const std::string& what,
            const ProgramResult& r, const std::string& why) {
  ++failures;
  const std::string kept = fs::temp_directory_path() / ("fem_cloth_fuzz_failure_" + std::to_string(::getpid()) +
                                                        "_" + std::to_string(failures) +
                                                        fs::path(input).extension().string());
  fs::copy_file(input, kept, fs::copy_options::overwrite_existing);
  ADD_FAILURE() << tool << ": " << why << " (seed " << kSeed << "; mutations: " << what << ")\n"
                << "input kept as " << kept << "\nstatus " << r.status << "\nstderr:\n" << r.err;
}

// The error lines of a run: stderr without warnings and progress lines.
std::vector<std::string> errorLines(const std::string& err) {
  std::vector<std::string> out;
  for (const std::string& line : splitLines(err)) {
    if (line.find(": warning: ") != std::string::npos || line.rfind("progress:", 0) == 0) continue;
    out.push_back(line);
  }
  return out;
}

// A run of fem_cloth_sim ended as documented: 0, 3 or 2, a refusal in one line; with --verify
// (`verify`) also 4, states not reproduced bit for bit.
void checkSim(const ProgramResult& r, const std::string& input, const std::string& what, bool verify = false) {
  if (r.status != 0 && r.status != 2 && r.status != 3 && !(verify && r.status == 4)) {
    report("fem_cloth_sim", input, what, r, "status " + std::to_string(r.status) + " (killed or crashed)");
    return;
  }
  const std::vector<std::string> errors = errorLines(r.err);
  if (r.status == 2 && (errors.size() != 1 || errors[0].rfind("fem_cloth_sim: ", 0) != 0)) {
    report("fem_cloth_sim", input, what, r, "a refusal must be one line 'fem_cloth_sim: ...'");
  }
}

ProgramResult runSim(const std::vector<std::string>& args) {
  return fem_cloth::test::runProgramWithin(kTimeBound, kSim, args, scratch());
}

ProgramResult runPython(const std::string& script, const std::vector<std::string>& args) {
  std::vector<std::string> all = {script};
  all.insert(all.end(), args.begin(), args.end());
  return fem_cloth::test::runProgramWithin(kTimeBound, "/usr/bin/python3", all, scratch());
}

// A small recording: a 4 x 4 cloth run by fem_cloth_sim into a bag, with pin and force commands
// and a gripper frame added, written uncompressed or compressed.
std::string recording(const std::string& name, rosbag::compression::CompressionType compression) {
  const std::string scene = scratch().write("rec_scene.yaml", R"(name: rec
mesh: {type: grid, rows: 4, cols: 4, width: 0.3, height: 0.3}
material: {model: stvk, youngs_modulus: 2.0e6, poisson_ratio: 0.3}
integrator: {name: backward_euler, dt: 0.01}
pins: [{grid_vertices: [[0, 0], [0, -1]]}]
duration: 0.1
)");
  const std::string plain = scratch().path("rec_plain.bag");
  const ProgramResult r = runSim({"--scene", scene, "--out", plain, "--every", "2", "-q"});
  EXPECT_EQ(r.status, 0) << r.err;
  const std::string path = scratch().path(name);
  rosbag::Bag in(plain), out(path, rosbag::bagmode::Write);
  out.setCompression(compression);
  out.setChunkThreshold(4096);  // several chunks: damage hits one of them
  // ~stats carries the steps' wall times: left in, the compressed recordings' layout, and with it
  // where the seeded mutations land, changed from run to run (a crash seen in one run of three).
  for (const rosbag::MessageInstance& m : rosbag::View(in)) {
    if (m.getTopic() != "/fem_cloth_node/stats") out.write(m.getTopic(), m.getTime(), m);
  }
  for (int k = 0; k <= 10; ++k) {
    tf2_msgs::TFMessage tf;
    tf.transforms.resize(1);
    tf.transforms[0].header.stamp = ros::Time(0.01 * k + 1e-6);
    tf.transforms[0].header.frame_id = "world";
    tf.transforms[0].child_frame_id = "gripper";
    tf.transforms[0].transform.translation.z = 0.01 * k;
    tf.transforms[0].transform.rotation.w = 1.0;
    out.write("/tf", tf.transforms[0].header.stamp, tf);
  }
  fem_cloth::PinCommand pin;
  pin.header.stamp = ros::Time(0.03);
  pin.header.frame_id = "gripper";
  pin.action = fem_cloth::PinCommand::PIN_IN_PLACE;
  pin.vertices = {15};
  out.write("/fem_cloth_node/applied_pin", pin.header.stamp, pin);
  fem_cloth::ForceCommand force;
  force.header.stamp = ros::Time(0.05);
  force.header.frame_id = "world";
  force.action = fem_cloth::ForceCommand::APPLY;
  force.vertices = {5};
  force.forces.resize(1);
  force.forces[0].y = 0.1;
  force.duration = 0.02;
  out.write("/fem_cloth_node/applied_force", force.header.stamp, force);
  return path;
}

// The positions of every ClothState in a bag, by step (empty when rosbag cannot read it).
std::map<std::uint64_t, std::vector<double>> recordedPositions(const std::string& path) {
  std::map<std::uint64_t, std::vector<double>> out;
  try {
    rosbag::Bag bag(path);
    for (const rosbag::MessageInstance& m : rosbag::View(bag)) {
      const fem_cloth::ClothState::ConstPtr s = m.instantiate<fem_cloth::ClothState>();
      if (!s) continue;
      std::vector<double>& xs = out[s->step];
      xs.clear();
      for (const auto& p : s->positions) xs.insert(xs.end(), {p.x, p.y, p.z});
    }
  } catch (const std::exception&) {
    return {};
  }
  return out;
}

// Whether a damaged bag still reads as states and one of them differs, bit for bit, from the
// intact bag's state of the same step (a truncated bag whose states are all right does not).
bool statesDiffer(const std::string& damaged, const std::string& intact) {
  const std::map<std::uint64_t, std::vector<double>> a = recordedPositions(damaged), b = recordedPositions(intact);
  for (const auto& [step, xs] : a) {
    const auto it = b.find(step);
    if (it == b.end()) continue;  // a step number damaged: nothing to compare with
    if (xs.size() != it->second.size()) return true;
    if (std::memcmp(xs.data(), it->second.data(), xs.size() * sizeof(double)) != 0) return true;
  }
  return false;
}

// A recording with `commands` written into it at their stamps (a command stream as a node would
// record it on ~applied_<topic>; some of them invalid).
template <class M>
void writeCommand(rosbag::Bag& bag, const std::string& topic, const M& m) {
  bag.write("/fem_cloth_node/applied_" + topic, m.header.stamp.isZero() ? ros::Time(1e-9) : m.header.stamp, m);
}

std::string withCommandStream(const std::string& base, const std::string& path, Random& random, std::string& what) {
  rosbag::Bag in(base), out(path, rosbag::bagmode::Write);
  for (const rosbag::MessageInstance& m : rosbag::View(in)) out.write(m.getTopic(), m.getTime(), m);
  const std::vector<std::string> pairs = {"damping.mass=0.3", "gravity=[0, 0, -2]", "material.poisson_ratio=0.7",
                                          "material.youngs_modulus=4.0e6", "mesh.rows=9", "bending.stiffness=1e-5"};
  const std::vector<std::string> entries = {"{type: sphere, center: [0.15, 0.15, -1], radius: 0.1}",
                                            "{type: sphere, center: [0.15, 0.15, 0], radius: 1.0e4}",
                                            "{type: plane, point: [0, 0, -2], normal: [0, 0, 1]}",
                                            "{type: box, center: [0, 0, -3], size: [1, 1, 1]}", "{center: [0, 0, -2]}",
                                            "{radius: -1}", "[1, 2]"};
  const std::size_t n = 1 + random.below(8);
  for (std::size_t k = 0; k < n; ++k) {
    const ros::Time stamp(0.001 * static_cast<double>(random.below(100)));
    const std::string at = " at " + std::to_string(stamp.toSec()) + " s; ";
    switch (random.below(5)) {
      case 0: {
        fem_cloth::PinCommand c;
        c.header.stamp = stamp;
        c.header.frame_id = random.below(4) == 0 ? "gripper" : "world";
        c.action = static_cast<std::uint8_t>(1 + random.below(2));  // PIN_IN_PLACE or RELEASE
        c.vertices = {static_cast<std::uint32_t>(random.below(18))};  // 16 and 17 do not exist
        what += "pin " + std::to_string(c.vertices[0]) + " in " + c.header.frame_id + at;
        writeCommand(out, "pin", c);
        break;
      }
      case 1: {
        fem_cloth::ForceCommand c;
        c.header.stamp = stamp;
        c.header.frame_id = "world";
        c.action = fem_cloth::ForceCommand::APPLY;
        c.vertices = {static_cast<std::uint32_t>(random.below(16))};
        c.forces.resize(1);
        c.forces[0].z = random.below(6) == 0 ? 1e30 : 0.01 * static_cast<double>(random.below(10));
        c.duration = 0.01 * static_cast<double>(random.below(5));
        what += "force " + std::to_string(c.forces[0].z) + " N" + at;
        writeCommand(out, "force", c);
        break;
      }
      case 2: {
        fem_cloth::SetCommand c;
        c.header.stamp = stamp;
        c.pairs = {random.pick(pairs)};
        what += "set " + c.pairs[0] + at;
        writeCommand(out, "set", c);
        break;
      }
      case 3: {
        fem_cloth::ObstacleCommand c;
        c.header.stamp = stamp;
        c.action = static_cast<std::uint8_t>(random.below(3));
        c.name = random.below(5) == 0 ? "other" : "ball";
        c.entry = c.action == fem_cloth::ObstacleCommand::REMOVE ? "" : random.pick(entries);
        what += "obstacle " + std::to_string(c.action) + " '" + c.name + "' " + c.entry + at;
        writeCommand(out, "obstacle", c);
        break;
      }
      default: {
        fem_cloth::GraspCommand c;
        c.header.stamp = stamp;
        c.header.frame_id = "world";
        c.point.x = c.point.y = 0.1 * static_cast<double>(random.below(4));
        c.radius = random.below(4) == 0 ? 1e-6 : 0.15;
        what += "grasp (" + std::to_string(c.point.x) + ", " + std::to_string(c.point.y) + ") r " +
                std::to_string(c.radius) + at;
        writeCommand(out, "grasp", c);
      }
    }
  }
  return path;
}

}  // namespace

// Inputs that crashed the tools before: each is refused in one line, with status 2 — except a
// recording whose only fault is a command stamped where no ROS duration reaches: the node
// refused that command when it came, so the replay leaves it out with one warning naming it
// (status 0; docs/replay.md).
TEST(Fuzz, InputsThatCrashedBeforeAreRefused) {
  const std::string leftOut = "command_stamp_4294967295.bag";
  int count = 0;
  for (const auto& e : fs::directory_iterator(kRegressions)) {
    const std::string path = e.path().string();
    const std::string ext = e.path().extension().string();
    if (ext != ".yaml" && ext != ".bag") continue;
    ++count;
    const ProgramResult r = ext == ".yaml"
                                ? runSim({"--scene", path, "--no-output", "-q"})
                                : runSim({"--commands", path, "--out", scratch().path("regression_out.bag"), "-q"});
    if (e.path().filename() == leftOut) {
      EXPECT_EQ(r.status, 0) << path << "\n" << r.err;
      EXPECT_NE(r.err.find("left out"), std::string::npos) << path << "\n" << r.err;
      continue;
    }
    EXPECT_EQ(r.status, 2) << path << "\n" << r.err;
    EXPECT_EQ(errorLines(r.err).size(), 1u) << path << "\n" << r.err;
    EXPECT_EQ(r.err.find(kPasswdBytes), std::string::npos) << path << "\n" << r.err;
  }
  EXPECT_GT(count, 0) << "no regression inputs in " << kRegressions;
}

TEST(Fuzz, MutatedScenes) {
  std::printf("[ fuzz     ] seed %llu\n", static_cast<unsigned long long>(kSeed));
  Random random(kSeed);
  scratch().write("mesh.obj", kObj);
  // The unmutated scenes run.
  for (std::size_t i = 0; i < kScenes.size(); ++i) {
    const std::string file = scratch().write("base_" + std::to_string(i) + ".yaml", kScenes[i]);
    const ProgramResult r = runSim({"--scene", file, "--no-output", "-q"});
    EXPECT_EQ(r.status, 0) << "base scene " << i << ": " << r.err;
  }
  std::map<int, int> statuses;
  const int cases = 120 * kCaseFactor;
  for (int c = 0; c < cases; ++c) {
    const std::size_t base = random.below(kScenes.size());
    std::string what = "scene " + std::to_string(base) + ": ";
    std::string text = kScenes[base];
    const std::size_t mutations = 1 + random.below(3);
    for (std::size_t m = 0; m < mutations; ++m) text = mutateScene(text, random, what);
    const std::string file = scratch().write("case.yaml", text);
    // Every tenth case writes its outputs too.
    const bool write = c % 10 == 0;
    const ProgramResult r = write ? runSim({"--scene", file, "--out", scratch().path("case_out"), "-q"})
                                  : runSim({"--scene", file, "--no-output", "-q"});
    ++statuses[r.status];
    checkSim(r, file, what);
    if (failures > 10) break;
  }
  std::printf("[ fuzz     ] %d mutated scenes: %d ran (0), %d refused (2), %d failed (3)\n", cases,
              statuses[0], statuses[2], statuses[3]);
  // The mutations must reach both sides: scenes that still run and scenes refused.
  EXPECT_GT(statuses[0], cases / 20);
  EXPECT_GT(statuses[2], cases / 4);
}

TEST(Fuzz, MutatedBags) {
  Random random(kSeed + 1);
  const std::vector<std::string> bases = {recording("plain.bag", rosbag::compression::Uncompressed),
                                          recording("lz4.bag", rosbag::compression::LZ4),
                                          recording("bz2.bag", rosbag::compression::BZ2)};
  // The unmutated recordings replay.
  for (const std::string& b : bases) {
    const ProgramResult r = runSim({"--commands", b, "--out", scratch().path("base_out.bag"), "-q"});
    EXPECT_EQ(r.status, 0) << b << ": " << r.err;
  }
  std::map<int, int> statuses;
  const int cases = 36 * kCaseFactor;
  int damagedStates = 0;
  for (int c = 0; c < cases; ++c) {
    const std::size_t base = random.below(bases.size());
    std::string what = fs::path(bases[base]).filename().string() + ": ";
    std::string bytes = readBytes(bases[base]);
    const std::size_t mutations = 1 + random.below(2);
    for (std::size_t m = 0; m < mutations; ++m) bytes = mutateBag(bytes, random, what);
    const std::string file = scratch().path("case.bag");
    writeBytes(file, bytes);
    const ProgramResult r = runSim({"--commands", file, "--out", scratch().path("case_out.bag"), "-q"});
    ++statuses[r.status];
    checkSim(r, file, what);
    // A bag whose states differ from the recording's (as rosbag reads them, independently of the
    // tools) never verifies: --verify re-simulates and compares (issue 31, part 1).
    if (statesDiffer(file, bases[base])) {
      ++damagedStates;
      const ProgramResult v = runSim({"--commands", file, "--verify", "--no-output", "-q"});
      checkSim(v, file, what + "--verify; ", true);
      if (v.status == 0) report("fem_cloth_sim --verify", file, what, v, "damaged states verified (status 0)");
    }
    // The comparison of the damaged bag with the intact one, for some of them.
    if (c % 4 == 0) {
      const ProgramResult d = runPython(kBagdiff, {file, bases[base]});
      if (d.status != 0 && d.status != 1 && d.status != 2) {
        report("fem_cloth_bagdiff", file, what, d, "status " + std::to_string(d.status));
      } else if (d.status == 2 && errorLines(d.err).size() != 1) {
        report("fem_cloth_bagdiff", file, what, d, "a refusal must be one line");
      }
    }
    if (c % 12 == 0) {
      const ProgramResult b = runPython(kBagReport, {file, "--out", scratch().path("report"), "--snapshots", "1"});
      if (b.status != 0 && b.status != 2) report("bag_report.py", file, what, b, "status " + std::to_string(b.status));
    }
    if (failures > 10) break;
  }
  std::printf("[ fuzz     ] %d damaged bags: %d replayed (0), %d refused (2), %d failed (3); %d with states "
              "damaged, none verified\n", cases, statuses[0], statuses[2], statuses[3], damagedStates);
  EXPECT_GT(statuses[2], cases / 4);
}

// Command streams as a live run records them, some commands invalid, into a recording: every
// replay ends as documented, and one that succeeds wrote finite states, the same bit for bit
// when the stream is replayed again (as rosbag reads them, not as the tools report).
TEST(Fuzz, CommandStreams) {
  Random random(kSeed + 2);
  const std::string base = recording("streams.bag", rosbag::compression::Uncompressed);
  std::map<int, int> statuses;
  const int cases = 40 * kCaseFactor;
  for (int c = 0; c < cases; ++c) {
    std::string what;
    const std::string file = withCommandStream(base, scratch().path("stream.bag"), random, what);
    const std::string first = scratch().path("stream_first.bag"), again = scratch().path("stream_again.bag");
    const ProgramResult r = runSim({"--commands", file, "--out", first, "-q"});
    ++statuses[r.status];
    checkSim(r, file, what);
    if (r.status == 0) {
      const ProgramResult r2 = runSim({"--commands", file, "--out", again, "-q"});
      if (r2.status != 0) report("fem_cloth_sim", file, what, r2, "a second replay ended otherwise");
      const std::map<std::uint64_t, std::vector<double>> states = recordedPositions(first);
      if (states.empty()) report("fem_cloth_sim", file, what, r, "status 0 but no states written");
      for (const auto& [step, xs] : states) {
        if (!std::all_of(xs.begin(), xs.end(), [](double x) { return std::isfinite(x); })) {
          report("fem_cloth_sim", file, what, r, "status 0 with a state not finite at step " + std::to_string(step));
          break;
        }
      }
      if (statesDiffer(again, first)) report("fem_cloth_sim", file, what, r2, "two replays of one stream differ");
    }
    if (failures > 10) break;
  }
  std::printf("[ fuzz     ] %d command streams: %d replayed (0), %d refused (2), %d failed (3)\n", cases,
              statuses[0], statuses[2], statuses[3]);
  EXPECT_GT(statuses[0], cases / 4);
}

// Issue 31's repro of --verify: a recording whose states were moved (by 1 m in z from step 4
// on, hashes kept), hold a NaN, or miss a vertex never verifies (4: not reproduced; 2: damaged).
TEST(Fuzz, ATamperedRecordingNeverVerifies) {
  const std::string base = recording("tamper_base.bag", rosbag::compression::Uncompressed);
  const std::vector<std::pair<std::string, std::function<void(fem_cloth::ClothState&)>>> tampers = {
      {"moved", [](fem_cloth::ClothState& s) { for (auto& p : s.positions) p.z += 1.0; }},
      {"nan", [](fem_cloth::ClothState& s) { s.positions[3].x = std::nan(""); }},
      {"short", [](fem_cloth::ClothState& s) { s.positions.pop_back(); }}};
  for (const auto& [name, tamper] : tampers) {
    const std::string file = scratch().path("tampered_" + name + ".bag");
    {
      rosbag::Bag in(base), out(file, rosbag::bagmode::Write);
      for (const rosbag::MessageInstance& m : rosbag::View(in)) {
        fem_cloth::ClothState::ConstPtr s = m.instantiate<fem_cloth::ClothState>();
        if (!s || s->step < 4) {
          out.write(m.getTopic(), m.getTime(), m);
          continue;
        }
        fem_cloth::ClothState changed = *s;
        tamper(changed);
        out.write(m.getTopic(), m.getTime(), changed);
      }
    }
    ASSERT_TRUE(statesDiffer(file, base)) << name;
    const ProgramResult v = runSim({"--commands", file, "--verify", "--no-output", "-q"});
    EXPECT_EQ(v.status, name == "moved" ? 4 : 2) << name << "\n" << v.err;
  }
}

// No refusal echoes a file that is not a scene (issue 31, part 4): given as the scene, named as
// a preset by a scene, a --set, or the scene stored in a bag.
TEST(Fuzz, NoRefusalEchoesAFileThatIsNotAScene) {
  const std::string secret = scratch().write("passwd", "secretuser:x:1000:1000::/home/secretuser:/bin/sh\n");
  const std::string scene = scratch().write("preset_scene.yaml", kScenes[0]);
  const std::string deep = "../../../../../../../../../../../../etc/passwd";
  const std::string bag = scratch().path("preset_scene.bag");
  {
    rosbag::Bag in(recording("preset_base.bag", rosbag::compression::Uncompressed)), out(bag, rosbag::bagmode::Write);
    for (const rosbag::MessageInstance& m : rosbag::View(in)) {
      const std_msgs::String::ConstPtr text = m.instantiate<std_msgs::String>();
      if (!text || m.getTopic() != "/fem_cloth_node/scene") {
        out.write(m.getTopic(), m.getTime(), m);
        continue;
      }
      YAML::Node doc = YAML::Load(text->data);
      doc["material"]["preset"] = secret;
      YAML::Emitter e;
      e << doc;
      std_msgs::String changed;
      changed.data = e.c_str();
      out.write(m.getTopic(), m.getTime(), changed);
    }
  }
  const std::vector<std::vector<std::string>> runs = {
      {"--scene", secret, "--no-output", "-q"},
      {"--scene", scene, "--set", "material.preset=" + secret, "--no-output", "-q"},
      {"--scene", scene, "--set", "material.preset=" + deep, "--no-output", "-q"},
      {"--commands", bag, "--no-output", "-q"}};
  for (const std::vector<std::string>& args : runs) {
    const ProgramResult r = runSim(args);
    const std::string what = args[0] + " " + args[1] + (args.size() > 4 ? " " + args[3] : "");
    EXPECT_EQ(r.status, 2) << what << "\n" << r.err;
    EXPECT_EQ(errorLines(r.err).size(), 1u) << what << "\n" << r.err;
    EXPECT_EQ(r.err.find("secretuser"), std::string::npos) << what << "\n" << r.err;
    EXPECT_EQ(r.err.find(kPasswdBytes), std::string::npos) << what << "\n" << r.err;
  }
}
