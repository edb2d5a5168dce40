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
    // No shipped scene carries a key its own integrator ignores.
    EXPECT_TRUE(scene->warnings.empty()) << entry.path() << ": " << scene->warnings.front();
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
  expectParseError(variant("integrator.dt", "-0.01"), {"integrator.dt", "[1e-07, 100] s", "-0.01"});
  expectParseError(variant("mesh.rows", "1"),
                   {"mesh.rows", "[2, 10000000]", "got 1"});
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

// Keys of one integrator alone are read into its settings in the scene's options.
TEST(SceneYaml, IntegratorOwnKeysReachItsSettings) {
  const Expected<Scene> s = parse(variant("integrator.cfl_safety", "0.25"));
  ASSERT_TRUE(s.ok()) << s.error();
  const SymplecticEulerSettings se = s->integratorOptions.get<SymplecticEulerSettings>("symplectic_euler");
  EXPECT_EQ(se.cflSafety, 0.25);
  EXPECT_TRUE(se.autoSubstep);  // not given: the default
  const Expected<Scene> off = parse(variant("integrator.auto_substep", "false"));
  ASSERT_TRUE(off.ok()) << off.error();
  EXPECT_FALSE(off->integratorOptions.get<SymplecticEulerSettings>("symplectic_euler").autoSubstep);
  expectParseError(variant("integrator.chebyshev_rho", "1.0"), {"integrator.chebyshev_rho", "[0, 1)"});
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
  // contact.surface_tolerance: auto (the default) is contact.distance; a number is metres.
  EXPECT_EQ(surfaceTolerance(automatic->contact), automatic->contact.distance);
  const Expected<Scene> tolerance = parse(std::string(kBase) + "contact: {distance: 0.003, surface_tolerance: 0.02}\n");
  ASSERT_TRUE(tolerance.ok()) << tolerance.error();
  EXPECT_EQ(surfaceTolerance(tolerance->contact), 0.02);
  const Expected<Scene> autoTolerance = parse(std::string(kBase) + "contact: {distance: 0.003, surface_tolerance: auto}\n");
  ASSERT_TRUE(autoTolerance.ok()) << autoTolerance.error();
  EXPECT_EQ(surfaceTolerance(autoTolerance->contact), 0.003);
  expectParseError(std::string(kBase) + "contact: {surface_tolerance: -0.001}\n", {"contact.surface_tolerance", "auto", "at least 0"});
  expectParseError(std::string(kBase) + "contact: {surface_tolerance: deep}\n", {"contact.surface_tolerance"});

  const std::string sphere = "obstacles: [{type: sphere, center: [0, 0, 1], radius: 0.1";
  expectParseError(std::string(kBase) + sphere + ", size: [1, 1, 1]}]\n",
                   {"unknown key 'obstacles[0].size'", "known here", "radius"});
  expectParseError(std::string(kBase) + "obstacles: [{type: cone}]\n", {"obstacles[0].type", "cone", "capsule"});
  expectParseError(std::string(kBase) + "obstacles: [{center: [0, 0, 0]}]\n", {"obstacles[0].type", "required"});
  expectParseError(std::string(kBase) + "obstacles: [{type: box, center: [0, 0, 0]}]\n", {"obstacles[0].size", "required"});
  expectParseError(std::string(kBase) + "obstacles: [{type: capsule, radius: 0.1}]\n", {"obstacles[0].length"});
  expectParseError(std::string(kBase) + sphere + ", friction: -1}]\n", {"obstacles[0].friction"});
  expectParseError(std::string(kBase) + "obstacles: [{type: sphere, radius: 0}]\n", {"obstacles[0].radius", "[1e-06, 10000] m"});
  expectParseError(std::string(kBase) + "obstacles: [{type: plane, normal: [0, 0, 0]}]\n", {"obstacles[0].normal"});
  expectParseError(std::string(kBase) + sphere + ", frame: hand, velocity: [1, 0, 0]}]\n", {"obstacles[0]", "hand", "velocity"});
  expectParseError(std::string(kBase) + sphere + ", trajectory: [{time: 1, offset: [0, 0, 0]}, {time: 0.5, offset: [0, 0, 1]}]}]\n",
                   {"obstacles[0].trajectory[1].time", "later"});
  expectParseError(std::string(kBase) + sphere + ", name: 'my ball'}]\n", {"obstacles[0].name", "my ball"});
  expectParseError(std::string(kBase) + sphere + ", name: a}, {type: plane, name: a}]\n", {"obstacles[1].name", "'a'"});
  expectParseError(std::string(kBase) + "contact: {distance: 0}\n", {"contact.distance", "[1e-06, 1] m"});
  expectParseError(std::string(kBase) + "contact: {stiffness: -3}\n", {"contact.stiffness", "auto"});
  expectParseError(std::string(kBase) + "contact: {self_colision: true}\n", {"unknown key 'contact.self_colision'"});
  expectParseError(variant("integrator.name", "xpbd") + "\ncontact: {self_collision: true}\n",
                   {"contact.self_collision", "xpbd", "self-contact", "backward_euler, bdf2"});
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
  // that share no vertex (here about 0.18 m, a vertex's distance to the diagonal of its quad,
  // 0.25 m x 0.267 m: 0.25 x 0.267 / hypot(0.25, 0.267))...
  const Expected<Scene> coarse = parse(std::string(kBase) + "contact: {self_collision: true, distance: 0.2}\n");
  ASSERT_TRUE(coarse.ok()) << coarse.error();
  const Expected<Simulation> coarseSim = buildSimulation(*coarse);
  ASSERT_FALSE(coarseSim.ok());
  expectError(coarseSim.error(), {"contact.distance", "0.2", "share no vertex"});
  // ... and, with obstacles or self-collision, below the shortest rest edge (1 m / 4 = 0.25 m).
  const Expected<Scene> wide = parse(std::string(kBase) + "contact: {self_collision: true, distance: 0.3}\n");
  ASSERT_TRUE(wide.ok()) << wide.error();
  expectError(buildSimulation(*wide).error(), {"contact.distance", "0.3", "shortest rest edge", "0.25 m"});
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

  // A second YAML document after --- used to be ignored (issue 31): refused, naming the file.
  const std::string two = dir.write("two.yaml", std::string(kBase) + "---\nduration: 5\n");
  scene = loadScene(two);
  ASSERT_FALSE(scene.ok());
  expectError(scene.error(), {two, "2 YAML documents"});
  // One document that starts with --- is one document.
  EXPECT_TRUE(loadScene(dir.write("one.yaml", "---\n" + std::string(kBase))).ok());

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

// An integrator key that the chosen integrator does not read would take no effect. Given on the
// command line (--set, as loadScene's overrides) or as a node parameter it is an error naming
// the key, the integrator, the integrators that read it and the keys this one reads; in the
// scene file (a scene switched to another integrator keeps its own keys) it is a warning.
TEST(SceneYaml, IntegratorKeysTheIntegratorDoesNotReadAreRefusedWhenGiven) {
  const std::string fast = kConfigDir + "/hanging_cloth_fast.yaml";  // projective_dynamics
  const std::string hanging = kConfigDir + "/hanging_cloth.yaml";    // symplectic_euler
  auto expectRefused = [](const std::string& path, const std::vector<std::string>& overrides,
                          const std::vector<std::string>& mentions) {
    const Expected<Scene> s = loadScene(path, overrides);
    ASSERT_FALSE(s.ok()) << overrides.back();
    expectError(s.error(), mentions);
  };
  expectRefused(fast, {"integrator.newton_tolerance=1"},
                {"--set integrator.newton_tolerance", "integrator projective_dynamics does not use",
                 "read by backward_euler, bdf2", "projective_dynamics reads: ", "chebyshev_rho"});
  expectRefused(hanging, {"integrator.name=backward_euler", "integrator.iterations=5"},
                {"--set integrator.iterations", "integrator backward_euler does not use",
                 "read by xpbd, projective_dynamics", "newton_tolerance", "solver"});
  expectRefused(hanging, {"integrator.solver=lbfgs"},
                {"--set integrator.solver", "integrator symplectic_euler does not use",
                 "read by backward_euler, bdf2", "symplectic_euler reads: ", "cfl_safety"});
  // The integrator the overrides end with decides, whatever their order.
  expectRefused(fast, {"integrator.chebyshev_rho=0.5", "integrator.name=xpbd"},
                {"integrator.chebyshev_rho", "integrator xpbd does not use"});
  expectRefused(hanging, {"integrator={name: backward_euler, iterations: 3}"},
                {"--set integrator.iterations", "integrator backward_euler does not use"});
  for (const std::vector<std::string>& good :
       {std::vector<std::string>{"integrator.iterations=5", "integrator.name=xpbd"},
        {"integrator.name=bdf2", "integrator.solver=lbfgs"},
        {"integrator.error_ratio=0.05"},  // projective dynamics reads the displacement test too
        {"integrator={name: xpbd, iterations: 3}"}}) {
    const Expected<Scene> s = loadScene(good.front().find("error_ratio") == std::string::npos ? hanging : fast, good);
    EXPECT_TRUE(s.ok()) << good.front() << ": " << s.error();
  }
  // As node parameters (sceneDocumentFromParameters passes the keys under ~integrator/).
  const YAML::Node pd = YAML::Load("{integrator: {name: projective_dynamics, iterations: 7}}");
  const Status node = checkGivenIntegratorKeys(pd, {"iterations", "newton_tolerance"}, "parameter ~integrator/");
  ASSERT_FALSE(node.ok());
  expectError(node.error(), {"parameter ~integrator/newton_tolerance", "integrator projective_dynamics"});
  EXPECT_TRUE(checkGivenIntegratorKeys(pd, {"iterations", "dt", "name"}, "parameter ~integrator/").ok());
  // No integrator.name: the default integrator (backward_euler) decides.
  EXPECT_FALSE(checkGivenIntegratorKeys(YAML::Load("{mesh: {rows: 3}}"), {"iterations"}, "x").ok());
}

TEST(SceneYaml, IntegratorKeysInTheFileThatTheIntegratorDoesNotReadAreWarnings) {
  // hanging_cloth_fast.yaml gives projective dynamics' iterations and chebyshev_rho; switched
  // to backward Euler it loads, with one warning for each.
  const Expected<Scene> switched =
      loadScene(kConfigDir + "/hanging_cloth_fast.yaml", {"integrator.name=backward_euler", "material.model=stvk"});
  ASSERT_TRUE(switched.ok()) << switched.error();
  ASSERT_EQ(switched->warnings.size(), 2u);
  expectError(switched->warnings[0], {"integrator.iterations is ignored", "backward_euler", "projective_dynamics"});
  expectError(switched->warnings[1], {"integrator.chebyshev_rho is ignored", "backward_euler"});
  const Expected<Scene> own = parse(variant("integrator.max_newton_iterations", "5"));
  ASSERT_TRUE(own.ok()) << own.error();
  EXPECT_TRUE(own->warnings.empty());
  const Expected<Scene> foreign = parse(variant("integrator.cfl_safety", "0.5"));
  ASSERT_TRUE(foreign.ok()) << foreign.error();
  ASSERT_EQ(foreign->warnings.size(), 1u);
  expectError(foreign->warnings[0], {"integrator.cfl_safety", "backward_euler", "symplectic_euler"});
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

// YAML lets any node be a key (`? [a, b]: 1`) and any node stand where a scene expects a
// number, a word, a list or a map: every such shape, anywhere in the scene, is one error naming
// where it is (yaml-cpp throws when a list is read as a word; that used to abort the tools).
TEST(SceneYaml, ShapesYamlAllowsAndScenesDoNot) {
  expectParseError("? [a, b]\n: 1\n" + std::string(kBase), {"a key of 'scene' is a list, not a word"});
  expectParseError(variant("mesh", "{rows: 4, cols: 5, ? {x: 1} : 2}"), {"a key of 'mesh' is a map"});
  expectParseError(std::string(kBase) + "pins: [{? [0] : 1}]\n", {"a key of 'pins[0]' is a list"});
  expectParseError(std::string(kBase) + "obstacles: [{type: plane, ? [x] : 1}]\n",
                   {"a key of 'obstacles[0]' is a list"});
  expectParseError(std::string(kBase) + "pins: [{vertices: [0], trajectory: [{? [t] : 0}]}]\n",
                   {"a key of 'pins[0].trajectory[0]' is a list"});
  // A map or a list where a number or a word is expected, and the other way round.
  expectParseError(variant("mesh.rows", "{a: 1}"), {"mesh.rows", "whole number", "a map"});
  expectParseError(variant("mesh.width", "[1]"), {"mesh.width", "number", "a list"});
  expectParseError(variant("name", "[a, b]"), {"name", "word", "a list"});
  expectParseError(variant("integrator.name", "{be: 1}"), {"integrator.name", "word", "a map"});
  expectParseError(variant("material.youngs_modulus", "{E: 1}"), {"material.youngs_modulus", "a map"});
  expectParseError(variant("mesh", "5"), {"mesh", "map", "'5'"});
  expectParseError(variant("integrator", "[dt]"), {"integrator", "map", "a list"});
  expectParseError(std::string(kBase) + "pins: [5]\n", {"pins[0]", "map", "'5'"});
  expectParseError(std::string(kBase) + "pins: {a: 1}\n", {"pins", "list", "a map"});
  expectParseError(std::string(kBase) + "pins: [{vertices: {a: 1}}]\n", {"pins[0].vertices", "list"});
  expectParseError(std::string(kBase) + "pins: [{vertices: [[0]]}]\n", {"pins[0].vertices[0]", "a list"});
  expectParseError(std::string(kBase) + "pins: [{grid_vertices: [[0, {a: 1}]]}]\n",
                   {"pins[0].grid_vertices[0]", "a map"});
  expectParseError(std::string(kBase) + "initial: {positions: [7]}\n", {"initial.positions[0]", "map"});
  expectParseError(std::string(kBase) + "obstacles: [{type: [plane]}]\n", {"obstacles[0].type"});
  expectParseError(std::string(kBase) + "contact: {stiffness: [auto]}\n", {"contact.stiffness", "a list"});
  expectParseError(variant("gravity", "{z: -9.81}"), {"gravity", "list of 2 or 3 numbers", "a map"});
  // A document that is not a map at all. A text is described by its length, never echoed (it may
  // be a file that is not a scene: issue 31, part 4); 'just words' has 10 characters.
  expectParseError("[1, 2]\n", {"scene", "map", "a list"});
  expectParseError("just words\n", {"scene", "map", "a text of 10 characters", "not a scene"});
}

// A key given without a value (`rows:` or `rows: ~`) is refused, not silently given its default
// (rows: ~ used to become 2 rows). A section or list whose entries are all commented out is
// empty.
TEST(SceneYaml, KeysWithoutAValueAreRefused) {
  expectParseError(variant("mesh.rows", "~"), {"mesh.rows", "no value"});
  expectParseError(std::string(kBase) + "duration:\n", {"duration", "no value"});
  expectParseError(variant("material.youngs_modulus", "~"), {"material.youngs_modulus", "no value"});
  expectParseError(variant("integrator.name", "~"), {"integrator.name", "no value"});
  expectParseError(variant("integrator.auto_substep", "~"), {"integrator.auto_substep", "no value"});
  expectParseError(std::string(kBase) + "gravity: ~\n", {"gravity", "no value"});
  expectParseError(std::string(kBase) + "contact: {stiffness: ~}\n", {"contact.stiffness", "no value"});
  expectParseError(std::string(kBase) + "pins: [{vertices: [0], release_at: ~}]\n",
                   {"pins[0].release_at", "no value"});
  expectParseError(std::string(kBase) + "pins: [{vertices: [~]}]\n", {"pins[0].vertices[0]", "no value"});
  expectParseError(std::string(kBase) + "obstacles: [{type: sphere, radius: ~}]\n",
                   {"obstacles[0].radius", "no value"});
  const Expected<Scene> empty = parse(std::string(kBase) + "damping:\npins:\nobstacles: ~\n");
  ASSERT_TRUE(empty.ok()) << empty.error();
  EXPECT_TRUE(empty->pins.empty());
  EXPECT_TRUE(empty->obstacles.empty());
  EXPECT_EQ(empty->damping.massProportional, 0.0);
}

// Item 2 of issue 11: a scene needing more than 10^8 steps or 10^7 vertices is refused naming
// the key, before anything is allocated (mesh.rows: 1e9 and rows x cols beyond int used to
// abort on bad_alloc or overflow).
TEST(SceneYaml, RunSizesAreBounded) {
  expectParseError(variant("mesh.rows", "1e9"), {"mesh.rows", "10000000", "1000000000"});
  expectParseError(variant("mesh.rows", "1e10"), {"mesh.rows", "at most 10^9"});
  // 4000 x 4000 = 1.6e7 vertices, each count below the limit: the product is named.
  const std::string big = variant("mesh", "{rows: 4000, cols: 4000}");
  expectParseError(big, {"mesh.rows x mesh.cols", "4000 x 4000", "16000000 vertices", "10000000"});
  // 65536 x 65536 = 2^32 overflows int: still named, not wrapped around.
  expectParseError(variant("mesh", "{rows: 65536, cols: 65536}"), {"4294967296 vertices"});
  // 3000 x 3000 = 9e6 vertices is allowed (validated, not built here).
  EXPECT_TRUE(parse(variant("mesh", "{rows: 3000, cols: 3000}")).ok());
  // Steps: duration / dt x substeps. 1e6 s at 0.01 s is 1e8 steps, the most allowed.
  EXPECT_TRUE(parse(std::string(kBase) + "duration: 1.0e6\n").ok());
  expectParseError(std::string(kBase) + "duration: 1.0000001e6\n",
                   {"duration", "100000010 steps, more than the 100000000 allowed"});
  expectParseError(variant("integrator", "{dt: 1.0e-7}") + "\nduration: 11\n",
                   {"duration", "110000000 steps"});
  expectParseError(variant("integrator", "{dt: 0.01, substeps: 1000000}") + "\nduration: 2\n",
                   {"duration", "1000000 substeps", "200000000 steps"});
}

// Every physical key has a range (docs/scenes.md): values beyond it, though finite, are refused
// naming the key, the range and the value; the ends of each range are accepted.
TEST(SceneYaml, EveryPhysicalKeyHasASaneRange) {
  struct Case {
    std::string key, unit;
    std::string low, high;      // in range, at its ends
    std::string below, above;   // out of range ("" where the range is open or unbounded)
  };
  const std::vector<Case> cases = {
      {"mesh.width", "m", "1e-4", "1e3", "9.9e-5", "1.01e3"},
      {"mesh.height", "m", "1e-4", "1e3", "0", "1e300"},
      {"material.thickness", "m", "1e-6", "0.1", "0", "0.11"},
      {"material.density", "kg/m^3", "1", "1e5", "0.9", "1.1e5"},
      {"material.youngs_modulus", "Pa", "1", "1e12", "0.5", "2e12"},
      {"bending.stiffness", "N m", "0", "1e4", "-1e-9", "1.1e4"},
      {"damping.mass", "1/s", "0", "1e4", "-1", "1e300"},
      {"damping.stiffness", "s", "0", "10", "-1", "11"},
      {"integrator.dt", "s", "1e-7", "100", "9e-8", "101"},
      {"integrator.newton_tolerance", "1/s", "1e-12", "10", "0", "11"},
      {"integrator.error_ratio", "", "1e-6", "1", "0", "1.5"},
      {"integrator.error_cap", "", "1e-6", "0.5", "-0.01", "0.6"},
      {"integrator.error_floor", "cloth sizes", "1e-12", "0.01", "0", "0.02"},
      {"integrator.cg_tolerance", "", "1e-16", "0.1", "0", "0.2"},
      {"contact.distance", "m", "1e-6", "1e-2", "0", "1.5"},
      {"contact.stiffness", "m/s^2", "1e-3", "1e9", "", "2e9"},
      {"contact.friction_velocity", "m/s", "1e-8", "1", "0", "2"},
      {"contact.surface_stretch", "", "1", "10", "0.9", "11"},
      {"contact.surface_tolerance", "m", "0", "1", "", "1.1"},
      {"contact.self_friction", "", "0", "10", "-0.1", "11"},
  };
  for (const Case& c : cases) {
    // contact.self_friction needs self-contact (the base scene's contact has none).
    auto with = [&](const std::string& value) {
      if (c.key != "contact.self_friction") return variant(c.key, value);
      YAML::Node doc = YAML::Load(variant(c.key, value));
      doc["contact"]["self_collision"] = true;
      YAML::Emitter out;
      out << doc;
      return std::string(out.c_str());
    };
    for (const std::string& ok : {c.low, c.high}) {
      const Expected<Scene> s = parse(with(ok));
      EXPECT_TRUE(s.ok()) << c.key << " = " << ok << ": " << (s.ok() ? "" : s.error());
    }
    for (const std::string& bad : {c.below, c.above}) {
      if (bad.empty()) continue;
      const Expected<Scene> s = parse(with(bad));
      ASSERT_FALSE(s.ok()) << c.key << " = " << bad;
      expectError(s.error(), {c.key, "must be in", c.unit});
    }
  }
  // Integer keys.
  expectParseError(variant("integrator.substeps", "1000001"), {"integrator.substeps", "[1, 1000000]"});
  expectParseError(variant("integrator.max_retries", "21"), {"integrator.max_retries", "[0, 20]"});
  expectParseError(variant("integrator.max_newton_iterations", "10001"), {"integrator.max_newton_iterations"});
  EXPECT_TRUE(parse(variant("integrator.max_newton_iterations", "2")).ok());
  // One Newton iteration was refused while convergence needed a second, short Newton step (every
  // step was rolled back and substepped, 200x slower); since the test in displacement (issue 29)
  // the first step's correction is measured at once, and one iteration is a valid setting.
  EXPECT_TRUE(parse(variant("integrator.max_newton_iterations", "1")).ok());
  expectParseError(variant("integrator.max_newton_iterations", "0"), {"integrator.max_newton_iterations"});
  expectParseError(variant("integrator.max_backtracks", "201"), {"integrator.max_backtracks"});
  expectParseError(variant("integrator.iterations", "100001"), {"integrator.iterations"});
  expectParseError(variant("integrator.cg_max_iterations", "0"), {"integrator.cg_max_iterations"});
  // Vectors: their length.
  expectParseError(std::string(kBase) + "gravity: [0, 0, -1001]\n", {"gravity", "at most 1000 m/s^2"});
  EXPECT_TRUE(parse(std::string(kBase) + "gravity: [0, 0, -1000]\n").ok());
  expectParseError(std::string(kBase) + "initial: {velocity: [1001, 0, 0]}\n", {"initial.velocity", "1000 m/s"});
  expectParseError(std::string(kBase) + "pins: [{vertices: [0], velocity: [0, 0, 2000]}]\n",
                   {"pins[0].velocity", "1000 m/s"});
  expectParseError(std::string(kBase) + "forces: [{vertices: [0], force: [0, 0, 1.5e6]}]\n",
                   {"forces[0].force", "1e+06 N"});
  // Positions: within 10 km of the origin in each coordinate.
  expectParseError(variant("mesh.origin", "[0, 0, 1e300]"), {"mesh.origin", "10000 m", "1e+300"});
  EXPECT_TRUE(parse(variant("mesh.origin", "[0, 0, -1e4]")).ok());
  expectParseError(std::string(kBase) + "initial: {positions: [{vertex: 0, position: [2e4, 0, 0]}]}\n",
                   {"initial.positions[0].position", "10000 m"});
  expectParseError(std::string(kBase) + "obstacles: [{type: sphere, center: [0, 0, -1e5], radius: 1}]\n",
                   {"obstacles[0].center"});
  expectParseError(std::string(kBase) + "obstacles: [{type: sphere, center: [0, 0, -2], radius: 2e4}]\n",
                   {"obstacles[0].radius", "[1e-06, 10000] m"});
  expectParseError(std::string(kBase) + "obstacles: [{type: box, center: [0, 0, -2], size: [1, 1, 1], orientation: [0, 0, 11]}]\n",
                   {"obstacles[0].orientation[2]", "[-10, 10] rad"});
  expectParseError(std::string(kBase) + "obstacles: [{type: plane, normal: [0, 0, 1e-200]}]\n",
                   {"obstacles[0].normal", "zero"});
  // Lame parameters given directly.
  expectParseError(variant("material", "{mu: 1e13, lambda: 1}"), {"material.mu", "[1, 1e+12] Pa"});
  expectParseError(variant("material", "{mu: 1e6, lambda: -1}"), {"material.lambda", "[0, 1e+12] Pa"});
}

// Values that were once taken silently, doing something else than they say (issue 31, part 5):
// each refused naming its key. And what they are mistaken for stays accepted.
TEST(SceneYaml, ValuesOnceTakenSilentlyAreRefused) {
  struct Case {
    std::string text;
    std::vector<std::string> mentions;
  };
  const std::string base = kBase;
  const std::vector<Case> cases = {
      // Two numbers on a 3D cloth: the vertical component was left out (weightless cloth).
      {base + "gravity: [0, 0]\n", {"gravity", "3D", "[gx, gy, gz]"}},
      {base + "gravity: [0, -9.81]\n", {"gravity", "3D"}},
      // Friction of cloth on cloth without self-contact did nothing.
      {base + "contact: {self_friction: 0.3}\n", {"contact.self_friction", "contact.self_collision"}},
      {base + "contact: {self_collision: false, self_friction: 0.3}\n", {"contact.self_friction"}},
  };
  for (const Case& c : cases) expectParseError(c.text, c.mentions);
  // A planar scene's gravity has two numbers; a 3D scene's three.
  const std::string planar = R"(
name: planar
mesh: {type: grid, dim: 2, rows: 3, cols: 3, width: 1.0, height: 1.0}
material: {model: stvk, youngs_modulus: 1.0e6, poisson_ratio: 0.3, thickness: 1.0e-3, density: 1000}
gravity: [0, -9.81]
)";
  const Expected<Scene> s = parse(planar);
  ASSERT_TRUE(s.ok()) << s.error();
  EXPECT_EQ(s->gravity, Eigen::Vector3d(0.0, -9.81, 0.0));
  const Expected<Scene> cloth = parse(base + "gravity: [0, 0, -1]\n");
  ASSERT_TRUE(cloth.ok()) << cloth.error();
  EXPECT_EQ(cloth->gravity, Eigen::Vector3d(0.0, 0.0, -1.0));
}

// The scene's name names its output folder (fem_cloth_output/<name>): one word, which cannot
// climb out of the folder.
TEST(SceneYaml, SceneNamesAreWords) {
  for (const char* bad : {"../../x", "a/b", ".hidden", "..", "-rf", "two words", "tab\tname", "",
                          "ünïcode"}) {
    expectParseError(variant("name", std::string("'") + bad + "'"), {"name", "one word"});
  }
  const Expected<Scene> ok = parse(variant("name", "hanging_cloth-2.v1"));
  ASSERT_TRUE(ok.ok()) << ok.error();
  EXPECT_EQ(ok->name, "hanging_cloth-2.v1");
}

// Files that are no scene or OBJ text: a folder, a device, a binary file, a huge file give one
// error naming the file (a folder used to abort on an ios_base::failure, /dev/zero to read
// forever).
TEST(SceneYaml, ScenesAndMeshesReadOnlyBoundedTextFiles) {
  const TempDir dir("fem_cloth_test_scene_yaml_files");
  const std::string folder = dir.path("a_folder");
  std::filesystem::create_directories(folder);
  Expected<Scene> scene = loadScene(folder);
  ASSERT_FALSE(scene.ok());
  expectError(scene.error(), {folder, "is a directory"});
  scene = loadScene("/dev/zero");
  ASSERT_FALSE(scene.ok());
  expectError(scene.error(), {"/dev/zero", "not a regular file"});
  const std::string binary = dir.write("binary.yaml", std::string("name: x\0\x01\x02", 10));
  scene = loadScene(binary);
  ASSERT_FALSE(scene.ok());
  expectError(scene.error(), {binary, "not a text file", "offset 7"});
  // 17 MiB (a sparse file: nothing is written), beyond the 16 MiB a scene file may have.
  const std::string huge = dir.write("huge.yaml", "");
  std::filesystem::resize_file(huge, 17u << 20);
  scene = loadScene(huge);
  ASSERT_FALSE(scene.ok());
  expectError(scene.error(), {huge, "17825792 bytes", "16777216"});

  // OBJ meshes, named relative to the scene file.
  auto objScene = [&](const std::string& file) {
    return dir.write("obj.yaml", "mesh: {type: obj, file: '" + file + "'}\n"
                                 "material: {youngs_modulus: 1.0e6, poisson_ratio: 0.3}\n");
  };
  for (const auto& [file, why] : std::vector<std::pair<std::string, std::string>>{
           {"/dev/zero", "not a regular file"}, {"a_folder", "is a directory"}, {"nowhere.obj", "no such file"}}) {
    scene = loadScene(objScene(file));
    ASSERT_TRUE(scene.ok()) << scene.error();
    const Expected<Simulation> sim = buildSimulation(*scene);
    ASSERT_FALSE(sim.ok()) << file;
    expectError(sim.error(), {"mesh.file", file, why});
  }
  dir.write("binary.obj", std::string("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n\0\0", 34));
  scene = loadScene(objScene("binary.obj"));
  ASSERT_TRUE(scene.ok()) << scene.error();
  expectError(buildSimulation(*scene).error(), {"binary.obj", "not a text file", "offset 32"});
}

// A vertex no triangle uses would have no mass (the implicit steppers' matrix is singular
// there, "cholmod failed"): refused naming the vertex, in OBJ numbering too.
TEST(SceneYaml, AnUnusedVertexIsRefused) {
  const TempDir dir("fem_cloth_test_scene_yaml_unused");
  dir.write("unused.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 5 5\nv 1 1 0\nf 1 2 3\nf 2 5 3\n");
  const Expected<Scene> scene = loadScene(dir.write(
      "obj.yaml", "mesh: {type: obj, file: unused.obj}\nmaterial: {youngs_modulus: 1.0e6, poisson_ratio: 0.3}\n"));
  ASSERT_TRUE(scene.ok()) << scene.error();
  expectError(buildSimulation(*scene).error(),
              {"mesh", "vertex 3 (number 4 in an OBJ file) belongs to no triangle", "no mass"});
  const Expected<Scene> explicitMesh = parse(variant(
      "mesh", "{type: explicit, vertices: [[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 2, 2]], triangles: [[0, 1, 2]]}"));
  ASSERT_TRUE(explicitMesh.ok()) << explicitMesh.error();
  expectError(buildSimulation(*explicitMesh).error(), {"vertex 3", "belongs to no triangle"});
}

// The contact distance dHat is a gap the cloth keeps: it must be smaller than the mesh's shortest
// rest edge, and a free vertex must start at least dHat/2 from every obstacle (where the
// automatic barrier stiffness holds a resting cloth); the message says what dHat was compared
// with.
TEST(SceneYaml, TheContactDistanceFitsTheRestGaps) {
  // The base cloth lies in z = 0; a floor 1 mm below it.
  const std::string floor = "obstacles: [{name: floor, type: plane, point: [0, 0, -0.001]}]\n";
  const Expected<Scene> resting = parse(std::string(kBase) + floor + "contact: {distance: 0.002}\n");
  ASSERT_TRUE(resting.ok()) << resting.error();
  EXPECT_TRUE(buildSimulation(*resting).ok()) << "a cloth may start resting at dHat/2";
  const Expected<Scene> close = parse(std::string(kBase) + floor + "contact: {distance: 0.0021}\n");
  ASSERT_TRUE(close.ok()) << close.error();
  expectError(buildSimulation(*close).error(),
              {"contact.distance (0.0021 m)", "more than twice the gap", "vertex 0", "'floor'", "0.001 m"});
  // Issue 30: the explicit steppers' projection would throw a vertex closer than dHat out to it
  // in the first step: refused before it, naming the integrators whose barriers hold it.
  const Expected<Scene> projected =
      parse(variant("integrator.name", "symplectic_euler") + "\n" + floor + "contact: {distance: 0.0015}\n");
  ASSERT_TRUE(projected.ok()) << projected.error();
  expectError(buildSimulation(*projected).error(),
              {"'floor'", "vertex 0 starts 0.001 m", "within contact.distance (0.0015 m)",
               "symplectic_euler", "backward_euler, bdf2"});
  const Expected<Scene> clear =
      parse(variant("integrator.name", "symplectic_euler") + "\n" + floor + "contact: {distance: 0.001}\n");
  ASSERT_TRUE(clear.ok()) << clear.error();
  EXPECT_TRUE(buildSimulation(*clear).ok()) << "a vertex at dHat is where the projection puts it";
  const Expected<Scene> wide = parse(std::string(kBase) + "obstacles: [{type: plane, point: [0, 0, -1]}]\n"
                                     "contact: {distance: 0.26}\n");
  ASSERT_TRUE(wide.ok()) << wide.error();
  expectError(buildSimulation(*wide).error(), {"contact.distance (0.26 m)", "shortest rest edge", "0.25 m"});
}

namespace {

// Two triangles that share no vertex: a flat one, 1 m in the plane z = 0, and a vertical one
// whose lower corner is at depth `depth` below it (negative: above it).
std::string twoTriangles(double depth) {
  std::ostringstream s;
  s << "mesh: {type: explicit, vertices: [[0, 0, 0], [1, 0, 0], [0, 1, 0], "
    << "[0.2, 0.2, " << -depth << "], [0.2, 0.2, 0.5], [0.3, 0.3, 0.5]], triangles: [[0, 1, 2], [3, 4, 5]]}\n"
    << "material: {youngs_modulus: 1.0e6, poisson_ratio: 0.3}\n";
  return s.str();
}

}  // namespace

// With self_collision on, a rest mesh whose triangles pass through each other is refused naming
// the edge and the triangle (the barrier would hold them crossed); without it the crossing does
// not matter; initial positions are tested too.
TEST(SceneYaml, SelfCollisionNeedsAMeshThatDoesNotPassThroughItself) {
  const std::string self = "contact: {self_collision: true, distance: 0.001}\n";
  const Expected<Scene> pierced = parse(twoTriangles(0.1) + self);
  ASSERT_TRUE(pierced.ok()) << pierced.error();
  // Edge (3, 4) runs from z = -0.1 to 0.5 through (0.2, 0.2, 0), inside triangle 0.
  expectError(buildSimulation(*pierced).error(),
              {"rest mesh intersects itself", "edge (3, 4) of triangle 1 passes through triangle 0 (0, 1, 2)"});
  const Expected<Scene> apart = parse(twoTriangles(-0.1) + self);
  ASSERT_TRUE(apart.ok()) << apart.error();
  EXPECT_TRUE(buildSimulation(*apart).ok()) << buildSimulation(*apart).error();
  const Expected<Scene> noSelf = parse(twoTriangles(0.1));
  ASSERT_TRUE(noSelf.ok());
  EXPECT_TRUE(buildSimulation(*noSelf).ok());
  // The rest mesh apart, the initial positions crossing.
  const Expected<Scene> moved = parse(twoTriangles(-0.1) + self +
                                      "initial: {positions: [{vertex: 3, position: [0.2, 0.2, -0.1]}]}\n");
  ASSERT_TRUE(moved.ok()) << moved.error();
  expectError(buildSimulation(*moved).error(), {"initial", "edge (3, 4)", "triangle 0"});
}
