// Scenes in YAML: the shipped scenes load and build; every kind of bad input (unknown keys,
// wrong types, out-of-range values, malformed YAML, missing files, bad --set overrides) gives
// one error line that names the key; grid selectors count negative indices from the end.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "../temp_dir.h"
#include "fem_cloth/io/scene_yaml.h"

using namespace fem_cloth;
using fem_cloth::test::TempDir;

namespace {

const std::string kConfigDir = FEM_CLOTH_CONFIG_DIR;

/// A minimal valid scene; tests append or override keys.
const char* kBase = R"(
name: base
mesh: {type: grid, rows: 4, cols: 5, width: 1.0, height: 0.8}
material: {model: stvk, youngs_modulus: 1.0e6, poisson_ratio: 0.3, thickness: 1.0e-3, density: 1000}
integrator: {name: backward_euler, dt: 0.01}
)";

Expected<Scene> parse(const std::string& text) {
  YAML::Node doc;
  try {
    doc = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    return Error{std::string("test input is not YAML: ") + e.what()};
  }
  return parseScene(doc);
}

/// One line that names every word in `mentions`.
void expectError(const std::string& error, const std::vector<std::string>& mentions) {
  EXPECT_FALSE(error.empty());
  EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  for (const std::string& m : mentions) {
    EXPECT_NE(error.find(m), std::string::npos) << "'" << error << "' does not name '" << m << "'";
  }
}

void expectParseError(const std::string& text, const std::vector<std::string>& mentions) {
  const Expected<Scene> scene = parse(text);
  ASSERT_FALSE(scene.ok()) << text;
  expectError(scene.error(), mentions);
}

/// The base scene with one key (a dotted path of map keys) set to a YAML value.
std::string variant(const std::string& path, const std::string& value) {
  YAML::Node doc = YAML::Load(kBase);
  YAML::Node node = doc;
  std::stringstream parts(path);
  std::vector<std::string> keys;
  for (std::string k; std::getline(parts, k, '.');) keys.push_back(k);
  for (std::size_t i = 0; i + 1 < keys.size(); ++i) node.reset(node[keys[i]]);
  node[keys.back()] = YAML::Load(value);
  YAML::Emitter out;
  out << doc;
  return out.c_str();
}

}  // namespace

TEST(SceneYaml, EveryShippedSceneLoadsAndBuilds) {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(kConfigDir)) {
    if (entry.path().extension() != ".yaml") continue;
    names.push_back(entry.path().filename().string());
    const Expected<Scene> scene = loadScene(entry.path().string());
    ASSERT_TRUE(scene.ok()) << entry.path() << ": " << scene.error();
    const Expected<Simulation> sim = buildSimulation(*scene);
    ASSERT_TRUE(sim.ok()) << entry.path() << ": " << sim.error();
    EXPECT_GT(sim->model->numVertices(), 2);
    EXPECT_EQ(sim->simulator->integrator().name(), scene->integrator);
  }
  for (const char* expected :
       {"hanging_cloth.yaml", "planar_sheet.yaml", "seed_triangle.yaml", "stiff_cloth.yaml",
        "table_drape.yaml", "sphere_drape.yaml", "fold.yaml"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end()) << expected;
  }
}

TEST(SceneYaml, TheBaseSceneIsValid) {
  const Expected<Scene> scene = parse(kBase);
  ASSERT_TRUE(scene.ok()) << scene.error();
  EXPECT_EQ(scene->grid.rows, 4);
  EXPECT_EQ(scene->grid.cols, 5);
  EXPECT_TRUE(buildSimulation(*scene).ok());
}

TEST(SceneYaml, UnknownKeysAreNamed) {
  expectParseError(std::string(kBase) + "colour: red\n", {"unknown key 'colour'"});
  expectParseError(std::string(kBase) + "damping: {mass: 1, masss: 2}\n",
                   {"unknown key 'damping.masss'", "known here: mass, stiffness"});
  expectParseError(std::string(kBase) + "pins: [{grid_edges: first_row}]\n",
                   {"unknown key 'pins[0].grid_edges'"});
  expectParseError(std::string(kBase) + "initial: {positions: [{vertex: 1, pos: [0, 0]}]}\n",
                   {"initial.positions[0].pos"});
}

TEST(SceneYaml, WrongTypesAreNamed) {
  expectParseError(std::string(kBase) + "duration: soon\n", {"duration", "number", "'soon'"});
  expectParseError(std::string(kBase) + "gravity: 9.81\n", {"gravity", "list of 2 or 3 numbers"});
  expectParseError(std::string(kBase) + "gravity: [0, x, -9.81]\n", {"gravity[1]", "number"});
  expectParseError(std::string(kBase) + "pins: [{vertices: [0], velocity: [1, 2, three]}]\n",
                   {"pins[0].velocity[2]"});
  expectParseError(variant("integrator.auto_substep", "maybe"),
                   {"integrator.auto_substep", "true or false"});
  expectParseError(variant("integrator.substeps", "2.5"),
                   {"integrator.substeps", "whole number"});
  expectParseError(variant("material", "[1, 2]"), {"material", "map"});
  expectParseError(std::string(kBase) + "pins: {vertices: [0]}\n", {"pins", "list"});
}

TEST(SceneYaml, OutOfRangeValuesAreNamed) {
  expectParseError(variant("material.poisson_ratio", "0.7"),
                   {"material.poisson_ratio", "0.7"});
  expectParseError(variant("integrator.dt", "-0.01"), {"integrator.dt", "positive"});
  expectParseError(variant("mesh.rows", "1"),
                   {"mesh.rows", "at least 2"});
  expectParseError(variant("integrator.cfl_safety", "1.5"),
                   {"integrator.cfl_safety"});
  expectParseError(std::string(kBase) + "damping: {mass: -1}\n", {"damping.mass"});
  expectParseError(variant("integrator.name", "runge_kutta"),
                   {"integrator.name", "runge_kutta", "backward_euler"});
  expectParseError(variant("material.model", "rubber"),
                   {"material.model", "rubber"});
  expectParseError(std::string(kBase) + "pins: [{vertices: [0], release_at: 0}]\n",
                   {"pins[0].release_at"});
  expectParseError(std::string(kBase) + "duration: .inf\n", {"duration", "finite"});
}

TEST(SceneYaml, BuildErrorsNameTheirKey) {
  // Valid on their own, wrong against the mesh: found when the simulation is built.
  const Expected<Scene> pin = parse(std::string(kBase) + "pins: [{vertices: [20]}]\n");
  ASSERT_TRUE(pin.ok()) << pin.error();
  const Expected<Simulation> sim = buildSimulation(*pin);
  ASSERT_FALSE(sim.ok());
  expectError(sim.error(), {"pins[0]", "vertex 20", "20 vertices"});
  const Expected<Scene> planar =
      parse(variant("mesh.dim", "2") + "\nbending: {stiffness: 1e-3}\n");
  ASSERT_TRUE(planar.ok()) << planar.error();
  expectError(buildSimulation(*planar).error(), {"bending.stiffness", "planar"});
}

// Obstacles and contact: every key is read with its unit, a key of another shape or a missing
// one is named, and geometry that cannot work is an error naming the obstacle and the vertex.
TEST(SceneYaml, ObstaclesAndContact) {
  const Expected<Scene> scene = parse(std::string(kBase) + R"(
obstacles:
  - {name: table, type: box, center: [0.5, 0.4, -0.5], size: [2, 2, 1], orientation: [0, 0, 0.1], friction: 0.4}
  - {type: sphere, center: [0.5, 0.4, 0.3], radius: 0.1, velocity: [0, 0, 0.2]}
  - {name: finger, type: capsule, center: [0, 0, 0.05], radius: 0.01, length: 0.05, frame: gripper}
  - {name: floor, type: plane, point: [0, 0, -2], normal: [0, 0, 2],
     trajectory: [{time: 0, offset: [0, 0, 0]}, {time: 1, offset: [0, 0, 0.5]}]}
contact: {distance: 0.003, stiffness: 20, self_collision: true, self_friction: 0.2, friction_velocity: 0.002}
)");
  ASSERT_TRUE(scene.ok()) << scene.error();
  ASSERT_EQ(scene->obstacles.size(), 4u);
  EXPECT_EQ(scene->obstacles[0].name, "table");
  EXPECT_EQ(scene->obstacles[0].size, Eigen::Vector3d(2, 2, 1));
  EXPECT_EQ(scene->obstacles[0].orientation.z(), 0.1);
  EXPECT_EQ(scene->obstacles[0].friction, 0.4);
  EXPECT_EQ(scene->obstacles[1].name, "obstacle_1");
  EXPECT_EQ(scene->obstacles[1].velocity.z(), 0.2);
  EXPECT_EQ(scene->obstacles[2].frame, "gripper");
  EXPECT_EQ(scene->obstacles[3].trajectory.size(), 2u);
  EXPECT_EQ(scene->contact.distance, 0.003);
  EXPECT_EQ(scene->contact.stiffness, 20.0);
  EXPECT_TRUE(scene->contact.selfCollision);
  EXPECT_EQ(scene->contact.selfFriction, 0.2);
  EXPECT_EQ(scene->contact.frictionVelocity, 0.002);
  const Expected<Scene> automatic = parse(std::string(kBase) + "contact: {stiffness: auto}\n");
  ASSERT_TRUE(automatic.ok()) << automatic.error();
  EXPECT_EQ(automatic->contact.stiffness, 0.0);

  const std::string sphere = "obstacles: [{type: sphere, center: [0, 0, 1], radius: 0.1";
  expectParseError(std::string(kBase) + sphere + ", size: [1, 1, 1]}]\n",
                   {"unknown key 'obstacles[0].size'", "known here", "radius"});
  expectParseError(std::string(kBase) + "obstacles: [{type: cone}]\n", {"obstacles[0].type", "cone", "capsule"});
  expectParseError(std::string(kBase) + "obstacles: [{center: [0, 0, 0]}]\n", {"obstacles[0].type", "required"});
  expectParseError(std::string(kBase) + "obstacles: [{type: box, center: [0, 0, 0]}]\n", {"obstacles[0].size", "required"});
  expectParseError(std::string(kBase) + "obstacles: [{type: capsule, radius: 0.1}]\n", {"obstacles[0].length"});
  expectParseError(std::string(kBase) + sphere + ", friction: -1}]\n", {"obstacles[0].friction"});
  expectParseError(std::string(kBase) + "obstacles: [{type: sphere, radius: 0}]\n", {"obstacles[0].radius", "positive"});
  expectParseError(std::string(kBase) + "obstacles: [{type: plane, normal: [0, 0, 0]}]\n", {"obstacles[0].normal"});
  expectParseError(std::string(kBase) + sphere + ", frame: hand, velocity: [1, 0, 0]}]\n", {"obstacles[0]", "hand", "velocity"});
  expectParseError(std::string(kBase) + sphere + ", trajectory: [{time: 1, offset: [0, 0, 0]}, {time: 0.5, offset: [0, 0, 1]}]}]\n",
                   {"obstacles[0].trajectory[1].time", "later"});
  expectParseError(std::string(kBase) + sphere + ", name: 'my ball'}]\n", {"obstacles[0].name", "my ball"});
  expectParseError(std::string(kBase) + sphere + ", name: a}, {type: plane, name: a}]\n", {"obstacles[1].name", "'a'"});
  expectParseError(std::string(kBase) + "contact: {distance: 0}\n", {"contact.distance", "positive"});
  expectParseError(std::string(kBase) + "contact: {stiffness: -3}\n", {"contact.stiffness", "auto"});
  expectParseError(std::string(kBase) + "contact: {self_colision: true}\n", {"unknown key 'contact.self_colision'"});
  expectParseError(variant("integrator.name", "xpbd") + "\ncontact: {self_collision: true}\n",
                   {"contact.self_collision", "implicit", "xpbd"});
  expectParseError(variant("mesh.dim", "2") + "\nobstacles: [{type: plane}]\n", {"obstacles", "3D"});
  expectParseError(std::string(kBase) + "pins: [{vertices: [0], velocity: [1, 0, 0], trajectory: [{time: 0, offset: [0, 0, 0]}]}]\n",
                   {"pins[0]", "velocity or trajectory"});
}

TEST(SceneYaml, ContactBuildErrorsNameTheObstacleAndVertex) {
  // The base cloth lies in z = 0: a sphere around vertex 6 (at (0.25, 0.267, 0)) contains it.
  const Expected<Scene> inside = parse(std::string(kBase) + "obstacles: [{name: ball, type: sphere, center: [0.25, 0.267, 0], radius: 0.05}]\n");
  ASSERT_TRUE(inside.ok()) << inside.error();
  const Expected<Simulation> insideSim = buildSimulation(*inside);
  ASSERT_FALSE(insideSim.ok());
  expectError(insideSim.error(), {"obstacles[0]", "'ball'", "vertex 6", "inside"});
  // A pinned vertex may sit inside (the pin wins); one following a frame is placed later.
  const Expected<Scene> pinned = parse(std::string(kBase) + "pins: [{vertices: [6]}]\nobstacles: [{type: sphere, center: [0.25, 0.267, 0], radius: 0.05}]\n");
  ASSERT_TRUE(pinned.ok()) << pinned.error();
  EXPECT_TRUE(buildSimulation(*pinned).ok());
  // Self-collision: the contact distance must stay below the rest distance of parts of the cloth
  // that share no vertex (here about 0.19 m).
  const Expected<Scene> coarse = parse(std::string(kBase) + "contact: {self_collision: true, distance: 0.3}\n");
  ASSERT_TRUE(coarse.ok()) << coarse.error();
  const Expected<Simulation> coarseSim = buildSimulation(*coarse);
  ASSERT_FALSE(coarseSim.ok());
  expectError(coarseSim.error(), {"contact.distance", "0.3", "share no vertex"});
  const Expected<Scene> fine = parse(std::string(kBase) + "contact: {self_collision: true, distance: 0.01}\n");
  ASSERT_TRUE(fine.ok()) << fine.error();
  EXPECT_TRUE(buildSimulation(*fine).ok());
}

TEST(SceneYaml, PinTrajectoriesFollowTheirWaypoints) {
  const Expected<Scene> scene = parse(std::string(kBase) + R"(
gravity: [0, 0, 0]
pins: [{vertices: [0], trajectory: [{time: 0, offset: [0, 0, 0]}, {time: 0.1, offset: [0, 0, 0.1]}, {time: 0.3, offset: [0.2, 0, 0.1]}]}]
)");
  ASSERT_TRUE(scene.ok()) << scene.error();
  Expected<Simulation> sim = buildSimulation(*scene);
  ASSERT_TRUE(sim.ok()) << sim.error();
  Simulator& s = *sim->simulator;
  // Waypoints on step boundaries (dt = 0.01 s): the pin is exactly on the polyline.
  for (int step = 1; step <= 40; ++step) {
    ASSERT_TRUE(sim->script.applyDue(s).ok());
    ASSERT_TRUE(s.step().ok);
    const double t = step * 0.01;
    const Eigen::Vector3d expected = t <= 0.1 ? Eigen::Vector3d(0, 0, t)
                                   : t <= 0.3 ? Eigen::Vector3d(t - 0.1, 0, 0.1)
                                              : Eigen::Vector3d(0.2, 0, 0.1);
    EXPECT_LT((s.pinTarget(0) - expected).norm(), 1e-12) << "t = " << t;
    EXPECT_LT((s.state().x.head<3>() - expected).norm(), 1e-12) << "t = " << t;
  }
}

TEST(SceneYaml, FilesMalformedOrMissing) {
  const TempDir dir("fem_cloth_test_scene_yaml");
  const std::string bad = dir.write("bad.yaml", "name: bad\nmesh: [unclosed\n");
  Expected<Scene> scene = loadScene(bad);
  ASSERT_FALSE(scene.ok());
  expectError(scene.error(), {bad, "malformed YAML", "line"});

  const std::string missing = dir.write("ignored.yaml", "") + ".missing";
  scene = loadScene(missing);
  ASSERT_FALSE(scene.ok());
  expectError(scene.error(), {"cannot open", missing});

  // A file with a bad value: the error names the file and the key.
  const std::string wrong = dir.write("wrong.yaml", std::string(kBase) + "duration: -1\n");
  scene = loadScene(wrong);
  ASSERT_FALSE(scene.ok());
  expectError(scene.error(), {wrong, "duration"});
}

TEST(SceneYaml, Overrides) {
  const std::string hanging = kConfigDir + "/hanging_cloth.yaml";
  // Good overrides reach the scene, list entries included.
  Expected<Scene> scene = loadScene(hanging, {"integrator.dt=0.005", "mesh.rows=9",
                                              "integrator.name=bdf2", "pins.0.release_at=0.3",
                                              "gravity=[0, 0, -1.62]"});
  ASSERT_TRUE(scene.ok()) << scene.error();
  EXPECT_EQ(scene->dt, 0.005);
  EXPECT_EQ(scene->grid.rows, 9);
  EXPECT_EQ(scene->integrator, "bdf2");
  ASSERT_EQ(scene->pins.size(), 1u);
  EXPECT_EQ(scene->pins[0].releaseAt, 0.3);
  EXPECT_EQ(scene->gravity, Eigen::Vector3d(0, 0, -1.62));

  auto expectOverrideError = [&](const std::string& assignment,
                                 const std::vector<std::string>& mentions) {
    const Expected<Scene> s = loadScene(hanging, {assignment});
    ASSERT_FALSE(s.ok()) << assignment;
    expectError(s.error(), mentions);
  };
  expectOverrideError("material.colour=red", {"material.colour"});
  expectOverrideError("integrator.dt=fast", {"integrator.dt", "number", "'fast'"});
  expectOverrideError("mesh.rows=[1, 2]", {"mesh.rows"});
  expectOverrideError("integrator.dt", {"integrator.dt", "key.path=value"});
  expectOverrideError("integrator.dt=", {"integrator.dt=", "no value"});
  expectOverrideError("=3", {"'=3'"});
  expectOverrideError("integrator..dt=1", {"integrator..dt", "empty"});
  expectOverrideError("integrator.dt.x=1", {"integrator.dt.x", "'dt' is not a map"});
  expectOverrideError("pins.3.release_at=1", {"pins.3.release_at", "'3' is not an index"});
  expectOverrideError("duration=[", {"duration=[", "not valid YAML"});
}

// Grid selections: (row, col) with negative indices counting from the end, so -1 is the last
// row or column; vertex (r, c) of a rows x cols grid has index r cols + c (mesh.h).
TEST(SceneYaml, NegativeGridIndicesCountFromTheEnd) {
  const Expected<Scene> scene = parse(kBase);  // 4 rows x 5 cols
  ASSERT_TRUE(scene.ok());
  const int cols = 5;
  auto resolve = [&](std::vector<std::array<int, 2>> cells) {
    VertexSelection sel;
    sel.gridVertices = std::move(cells);
    return resolveSelection(sel, *scene, 20, "pins[0]");
  };
  EXPECT_EQ(*resolve({{-1, -1}}), std::vector<Index>{3 * cols + 4});
  EXPECT_EQ(*resolve({{0, -1}}), std::vector<Index>{4});
  EXPECT_EQ(*resolve({{-4, 0}}), std::vector<Index>{0});
  EXPECT_EQ(*resolve({{-2, 1}}), std::vector<Index>{2 * cols + 1});
  EXPECT_EQ(*resolve({{1, -5}}), std::vector<Index>{cols});
  // Duplicates collapse, results are sorted.
  EXPECT_EQ(*resolve({{3, 4}, {-1, -1}, {0, 0}}), (std::vector<Index>{0, 19}));
  // One past either end is an error naming the key and the cell.
  for (std::array<int, 2> outside : {std::array<int, 2>{-5, 0}, {0, -6}, {4, 0}, {0, 5}}) {
    const auto r = resolve({outside});
    ASSERT_FALSE(r.ok());
    expectError(r.error(), {"pins[0]", "grid vertex (" + std::to_string(outside[0]) + ", " +
                                           std::to_string(outside[1]) + ")", "4 x 5"});
  }
  // Edges.
  VertexSelection edge;
  edge.gridEdge = "last_col";
  EXPECT_EQ(*resolveSelection(edge, *scene, 20, "pins[0]"), (std::vector<Index>{4, 9, 14, 19}));
  edge.gridEdge = "last_row";
  EXPECT_EQ(*resolveSelection(edge, *scene, 20, "pins[0]"),
            (std::vector<Index>{15, 16, 17, 18, 19}));
  edge.gridEdge = "diagonal";
  expectError(resolveSelection(edge, *scene, 20, "pins[0]").error(),
              {"pins[0].grid_edge", "diagonal"});

  // The same through a scene file: the pinned vertices are the two far corners.
  const Expected<Scene> pinned =
      parse(std::string(kBase) + "pins: [{grid_vertices: [[-1, 0], [-1, -1]]}]\n");
  ASSERT_TRUE(pinned.ok()) << pinned.error();
  const Expected<Simulation> sim = buildSimulation(*pinned);
  ASSERT_TRUE(sim.ok()) << sim.error();
  EXPECT_EQ(sim->simulator->pinnedVertices(), (std::vector<Index>{15, 19}));
}

// YAML requires the keys of a map to be unique; yaml-cpp reads a repeated key without complaint
// and keeps the first value, so a repeated section would be silently ignored.
TEST(SceneYaml, RepeatedKeysAreNamed) {
  expectParseError(std::string(kBase) + "integrator: {name: xpbd}\n",
                   {"key 'integrator'", "more than once"});
  expectParseError(std::string(kBase) + "damping: {mass: 1, mass: 2}\n",
                   {"key 'damping.mass'", "more than once"});
}
