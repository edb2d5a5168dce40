// A scene: everything needed to set up a simulation, as plain C++ values in SI units, with
// validation that names the offending key. Reading scenes from YAML (files, --set overrides,
// ROS parameters) lives outside the core, in fem_cloth/io/scene_yaml.h; the key names used in
// messages are the YAML keys.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fem_cloth/core/bending_model.h"
#include "fem_cloth/core/contact/obstacle_set.h"
#include "fem_cloth/core/expected.h"
#include "fem_cloth/core/integrators/implicit.h"
#include "fem_cloth/core/integrators/projective_dynamics.h"
#include "fem_cloth/core/integrators/registry.h"
#include "fem_cloth/core/integrators/symplectic_euler.h"
#include "fem_cloth/core/integrators/xpbd.h"
#include "fem_cloth/core/materials/materials.h"
#include "fem_cloth/core/mesh.h"
#include "fem_cloth/core/simulator.h"

namespace fem_cloth {

/// Every position a scene gives (m) lies within this distance of the origin in each coordinate.
constexpr double kMaxCoordinate = 1e4;
/// The most steps (duration / dt x substeps) a scene may ask a tool to run.
constexpr std::uint64_t kMaxSteps = 100'000'000;

/// A set of vertices: explicit indices, grid coordinates (row, col; negative counts from the
/// end, so -1 is the last row or column), or a whole grid edge. Grid forms keep a scene valid
/// when its resolution changes. The union of all three is taken.
struct VertexSelection {
  std::vector<Index> vertices;
  std::vector<std::array<int, 2>> gridVertices;
  std::string gridEdge;  ///< "", first_row, last_row, first_col, last_col or all
  bool empty() const { return vertices.empty() && gridVertices.empty() && gridEdge.empty(); }
};

struct ScenePin {
  VertexSelection select;
  /// Targets: the rest position plus `offset` (m) unless explicit `targets` (one per vertex).
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> targets;
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< m/s, scripted pin motion
  /// Scripted motion through waypoints: the targets move by these offsets (m) at these times (s),
  /// linearly in between (held before the first and after the last); instead of velocity.
  std::vector<TrajectoryPoint> trajectory;
  double releaseAt = std::numeric_limits<double>::infinity();  ///< s
};

struct SceneForce {
  VertexSelection select;
  Eigen::Vector3d force = Eigen::Vector3d::Zero();  ///< N, on each selected vertex
  double start = 0.0;                                ///< s
  double duration = std::numeric_limits<double>::infinity();  ///< s
};

/// An obstacle as a scene gives it (docs/scenes.md, `obstacles`). Geometry in metres, in the
/// simulation frame or, with `frame`, in that tf frame.
struct SceneObstacle {
  std::string name;  ///< default obstacle_<index>; names the obstacle in messages and topics
  ShapeType type = ShapeType::Plane;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   ///< plane: a point on it
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< plane: outward normal (any length)
  Eigen::Vector3d center = Eigen::Vector3d::Zero();  ///< sphere, box, capsule
  Eigen::Vector3d size = Eigen::Vector3d::Zero();    ///< box: full extents along its axes
  Eigen::Vector3d orientation = Eigen::Vector3d::Zero();  ///< box, capsule: roll, pitch, yaw (rad)
  double radius = 0.0;  ///< sphere, capsule
  double length = 0.0;  ///< capsule: between the centres of its end caps, along its local z
  double friction = 0.0;
  std::string frame;
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< m/s
  std::vector<TrajectoryPoint> trajectory;
};

/// A named point of the cloth that the node publishes as a tf frame (docs/scenes.md, `frames`):
/// one vertex, by index or by grid coordinates.
struct SceneFrame {
  std::string name;
  VertexSelection select;  ///< exactly one vertex
};

struct SceneInitialPosition {
  Index vertex = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
};

/// How a scene gives its mesh (`mesh.type`): a generated grid, an OBJ file, or vertices and
/// triangles listed in the scene.
enum class MeshType { Grid, Obj, Explicit };

/// The names used in scenes, in the order of MeshType: grid, obj, explicit.
const std::vector<std::string>& meshTypeNames();
const std::string& meshTypeName(MeshType type);
/// The mesh type called `name`, if there is one.
std::optional<MeshType> meshTypeFromName(const std::string& name);

struct Scene {
  std::string name = "scene";
  std::string sourcePath;  ///< where it was read from (relative OBJ paths resolve against it)

  // mesh
  MeshType meshType = MeshType::Grid;
  GridSpec grid;
  std::string objFile;
  int dim = 3;  ///< for obj and explicit meshes (grid meshes use grid.dim)
  Mesh explicitMesh;
  double minTriangleQuality = 1e-4;

  // material: membrane moduli = volumetric moduli (Pa) x thickness (m)
  std::string materialModel = "stvk";
  std::optional<double> youngsModulus;  ///< Pa
  std::optional<double> poissonRatio;
  std::optional<double> mu;      ///< Pa (instead of youngsModulus and poissonRatio)
  std::optional<double> lambda;  ///< Pa
  double thickness = 5e-4;       ///< m
  double density = 2000.0;       ///< kg/m^3; areal density = density x thickness

  // bending
  BendingModel bendingModel = BendingModel::Midedge;
  double bendingStiffness = 0.0;     ///< N m; 0: no bending term at all
  double bendingPoissonRatio = 0.0;  ///< midedge: nu_b (docs/bending.md: why 0 for woven cloth)

  Damping damping;
  Eigen::Vector3d gravity{0.0, 0.0, -9.81};
  /// Aerodynamic drag and lift (core/air.h, docs/air.md); absent: no air code runs at all.
  std::optional<AirSettings> air;

  // integrator
  std::string integrator = "backward_euler";
  double dt = 0.01;
  int substeps = 1;
  int maxRetries = 4;
  NewtonSettings newton;
  /// Acceptance test (a) of the implicit steppers (integrator.error_ratio, error_cap,
  /// error_floor; the floor in cloth sizes).
  DisplacementTolerance displacement;
  int iterations = 10;  ///< xpbd: Gauss-Seidel sweeps; projective_dynamics: local/global iterations
  /// Keys of one integrator alone (symplectic_euler's auto_substep and cfl_safety,
  /// projective_dynamics' chebyshev_rho), in settings its registry entry defines (registry.h).
  IntegratorOptions integratorOptions;
  /// What the scene gives that takes no effect, worth logging once when it is loaded: keys under
  /// `integrator` that the chosen integrator does not read (a scene switched to another
  /// integrator). Given on the command line or as node parameters they are errors instead
  /// (checkGivenIntegratorKeys, io/scene_yaml.h).
  std::vector<std::string> warnings;

  std::vector<ScenePin> pins;
  std::vector<SceneForce> forces;
  std::vector<SceneObstacle> obstacles;
  ContactSettings contact;  ///< used only with obstacles or self_collision
  std::vector<SceneFrame> frames;  ///< used by the node only (tf frames of cloth points)
  std::vector<SceneInitialPosition> initialPositions;
  Eigen::Vector3d initialVelocity = Eigen::Vector3d::Zero();

  double duration = 2.0;  ///< s, how long tools run the scene by default
};

/// Range checks on every value, then what the integrator supports (registry.h); the message
/// names the YAML key.
Status validateScene(const Scene& scene);

/// value in [lo, hi], or an error naming `key` (unit: SI, for the message; may be empty).
Status inRange(double value, double lo, double hi, const std::string& key, const std::string& unit);
/// A whole number in [lo, hi], or an error naming `key`.
Status countInRange(int value, int lo, int hi, const std::string& key);
/// A vector of finite numbers, or an error naming `key`.
Status finiteVector(const Eigen::Vector3d& v, const std::string& key);
/// A position (m): every coordinate within kMaxCoordinate of the origin.
Status boundedPosition(const Eigen::Vector3d& p, const std::string& key);

/// The smallest obstacle radius or box size a scene may give (m).
constexpr double kMinObstacleSize = 1e-6;

/// The obstacle a scene entry describes; the message names the key (`key` is its path). Checked
/// in this order: name; center, orientation; the shape's keys (its entry, contact/shapes.h);
/// friction, velocity, trajectory, frame.
Expected<Obstacle> makeObstacle(const SceneObstacle& entry, const std::string& key);

/// The scene's cloth mesh at rest (its grid, OBJ file or explicit mesh).
Expected<Mesh> buildMesh(const Scene& scene);

/// The dimension of the scene's mesh (grid meshes keep it in grid.dim).
inline int meshDim(const Scene& scene) { return scene.meshType == MeshType::Grid ? scene.grid.dim : scene.dim; }

/// True when the scene needs contact (obstacles, or self-collision).
inline bool sceneHasContact(const Scene& scene) {
  return !scene.obstacles.empty() || scene.contact.selfCollision;
}

/// Per vertex: pinned by the scene from the start and never released (midedge bending treats
/// triangles with three such vertices as clamp plates). Errors as resolveSelection.
Expected<std::vector<char>> heldVertices(const Scene& scene, Index numVertices);

/// A run of more than kMaxSteps steps (duration / dt x substeps) is refused before it starts: at
/// the speeds reachable here it would not finish. `what` names the duration in the message.
Status checkStepCount(double duration, double dt, int substeps, const std::string& what);

/// The OBJ file a scene's mesh is read from, relative paths resolved against the scene file
/// ("" for other meshes).
std::string meshFilePath(const Scene& scene);

/// Membrane Lame parameters (N/m) of a scene: volumetric moduli times thickness.
Expected<Lame> membraneLame(const Scene& scene);

/// Timed commands of a scene (pin releases, forces that start later), applied as simulated time
/// passes.
class SceneScript {
 public:
  struct Event {
    double time = 0.0;
    enum class Kind { ReleasePin, ApplyForce, PinVelocity } kind = Kind::ReleasePin;
    Index vertex = 0;
    Eigen::Vector3d force = Eigen::Vector3d::Zero();
    Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< PinVelocity: the pin's new velocity
    double duration = 0.0;
  };
  void add(const Event& event);
  /// Applies every event due at or before the simulator's current time (once each).
  Status applyDue(Simulator& simulator);
  /// Makes every event due again (after Simulator::reset()).
  void rewind() { next_ = 0; }
  const std::vector<Event>& events() const { return events_; }

 private:
  std::vector<Event> events_;  // sorted by time
  std::size_t next_ = 0;
};

struct Simulation {
  std::shared_ptr<const Mesh> mesh;
  std::shared_ptr<Model> model;
  std::unique_ptr<Simulator> simulator;
  SceneScript script;
  std::vector<std::string> warnings;  ///< mesh warnings worth logging
};

/// Builds mesh, rest state, model (only the terms the scene declares), integrator and simulator,
/// applies initial state, pins and forces. Any problem is an error naming its key or element.
Expected<Simulation> buildSimulation(const Scene& scene);
/// The Simulator's settings a scene gives (gravity, damping, dt, substeps, retries).
SimulatorSettings simulatorSettings(const Scene& scene);

/// Resolves a selection against the scene's mesh.
Expected<std::vector<Index>> resolveSelection(const VertexSelection& selection, const Scene& scene,
                                              Index numVertices, const std::string& key);

}  // namespace fem_cloth
