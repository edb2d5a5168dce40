#include "fem_cloth/core/scene.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <set>
#include <sstream>

#include "fem_cloth/core/bending.h"
#include "fem_cloth/core/contact/self_intersection.h"
#include "fem_cloth/core/live_change.h"
#include "fem_cloth/core/membrane.h"

namespace fem_cloth {

const std::vector<std::string>& meshTypeNames() {
  static const std::vector<std::string> names = {"grid", "obj", "explicit"};
  return names;
}

const std::string& meshTypeName(MeshType type) { return enumName(meshTypeNames(), type); }

std::optional<MeshType> meshTypeFromName(const std::string& name) {
  return enumFromName<MeshType>(meshTypeNames(), name);
}

namespace {

// Sane ranges (docs/scenes.md): far beyond any cloth and scene this simulates, far inside where
// the arithmetic overflows.
constexpr double kMaxSpeed = 1e3;           // m/s: pins, obstacles, the initial velocity
constexpr double kMaxDuration = 1e9;        // s: durations and times of scripted events
constexpr double kMaxFriction = 10.0;       // Coulomb coefficients
constexpr double kMinModulus = 1.0;         // Pa: E, mu
constexpr double kMaxModulus = 1e12;        // Pa: E, mu, lambda (diamond: 1.2e12)
constexpr double kMinClothSize = 1e-4;      // m: a grid's width and height, a mesh's extent
constexpr double kMaxClothSize = 1e3;       // m

}  // namespace

Status finiteVector(const Eigen::Vector3d& v, const std::string& key) {
  if (!v.allFinite()) return Error{key + " must be finite"};
  return Status::success();
}

Status boundedPosition(const Eigen::Vector3d& p, const std::string& key) {
  FEM_CLOTH_CHECK(finiteVector(p, key));
  if (p.cwiseAbs().maxCoeff() > kMaxCoordinate) {
    return Error{key + " must lie within " + numberText(kMaxCoordinate) +
                 " m of the origin in every coordinate, got [" + numberText(p.x()) + ", " +
                 numberText(p.y()) + ", " + numberText(p.z()) + "]"};
  }
  return Status::success();
}

// The sane ranges of docs/scenes.md: finite values far outside what any cloth, time step or
// load can mean (damping.mass: 1e300) are refused like non-finite ones, before they overflow
// an energy or make a run of 10^300 substeps.

Status inRange(double value, double lo, double hi, const std::string& key, const std::string& unit) {
  if (!(value >= lo && value <= hi)) {
    return Error{key + " must be in [" + numberText(lo) + ", " + numberText(hi) + "]" +
                 (unit.empty() ? "" : " " + unit) + ", got " + numberText(value)};
  }
  return Status::success();
}

Status countInRange(int value, int lo, int hi, const std::string& key) {
  if (value < lo || value > hi) {
    return Error{key + " must be a whole number in [" + std::to_string(lo) + ", " +
                 std::to_string(hi) + "], got " + std::to_string(value)};
  }
  return Status::success();
}

namespace {

/// value in (0, hi].
Status positiveUpTo(double value, double hi, const std::string& key, const std::string& unit) {
  if (!(value > 0.0 && value <= hi)) {
    return Error{key + " must be in (0, " + numberText(hi) + "] " + unit + ", got " + numberText(value)};
  }
  return Status::success();
}

/// A finite vector no longer than maxNorm.
Status boundedVector(const Eigen::Vector3d& v, double maxNorm, const std::string& key,
                     const std::string& unit) {
  FEM_CLOTH_CHECK(finiteVector(v, key));
  if (v.norm() > maxNorm) {
    return Error{key + " must be at most " + numberText(maxNorm) + " " + unit + " long, got " +
                 numberText(v.norm()) + " " + unit};
  }
  return Status::success();
}

Status checkTrajectory(const std::vector<TrajectoryPoint>& trajectory, const std::string& key) {
  for (std::size_t k = 0; k < trajectory.size(); ++k) {
    const std::string at = key + ".trajectory[" + std::to_string(k) + "]";
    FEM_CLOTH_CHECK(inRange(trajectory[k].time, 0.0, kMaxDuration, at + ".time", "s"));
    FEM_CLOTH_CHECK(boundedVector(trajectory[k].offset, kMaxCoordinate, at + ".offset", "m"));
    if (k > 0 && !(trajectory[k].time > trajectory[k - 1].time)) {
      return Error{at + ".time must be later than the point before (" +
                   numberText(trajectory[k - 1].time) + " s), got " + numberText(trajectory[k].time)};
    }
  }
  return Status::success();
}

}  // namespace

namespace {

// A scene's name becomes a folder name (fem_cloth_output/<name>): one word, so that it cannot
// climb out of the output folder (`name: ../../x`) or name a hidden or special entry.
Status checkName(const std::string& name) {
  const bool word = !name.empty() && name.size() <= 100 && name[0] != '.' && name[0] != '-' &&
                    std::all_of(name.begin(), name.end(), [](char c) {
                      return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' ||
                             c == '.';
                    });
  if (!word) {
    return Error{"name must be one word of at most 100 letters, digits, '_', '-' and '.' (not "
                 "starting with '.' or '-'; it names the output folder), got '" + name + "'"};
  }
  return Status::success();
}

Status validateMeshKeys(const Scene& s) {
  if (s.meshType == MeshType::Grid) {
    FEM_CLOTH_CHECK(countInRange(s.grid.rows, 2, kMaxVertices, "mesh.rows"));
    FEM_CLOTH_CHECK(countInRange(s.grid.cols, 2, kMaxVertices, "mesh.cols"));
    const long long vertices = static_cast<long long>(s.grid.rows) * s.grid.cols;
    if (vertices > kMaxVertices) {
      return Error{"mesh.rows x mesh.cols = " + std::to_string(s.grid.rows) + " x " +
                   std::to_string(s.grid.cols) + " = " + std::to_string(vertices) +
                   " vertices, more than the " + std::to_string(kMaxVertices) + " allowed"};
    }
    FEM_CLOTH_CHECK(inRange(s.grid.width, kMinClothSize, kMaxClothSize, "mesh.width", "m"));
    FEM_CLOTH_CHECK(inRange(s.grid.height, kMinClothSize, kMaxClothSize, "mesh.height", "m"));
    FEM_CLOTH_CHECK(boundedPosition({s.grid.origin[0], s.grid.origin[1], s.grid.origin[2]}, "mesh.origin"));
    if (s.grid.dim != 2 && s.grid.dim != 3) {
      return Error{"mesh.dim must be 2 or 3, got " + std::to_string(s.grid.dim)};
    }
  } else if (s.meshType == MeshType::Obj) {
    if (s.objFile.empty()) return Error{"mesh.file is required for mesh.type obj"};
  }
  if ((s.meshType != MeshType::Grid) && s.dim != 2 && s.dim != 3) {
    return Error{"mesh.dim must be 2 or 3, got " + std::to_string(s.dim)};
  }
  if (s.meshType == MeshType::Explicit && s.explicitMesh.restPositions.size() > s.dim * Eigen::Index{kMaxVertices}) {
    return Error{"mesh.vertices has more than the " + std::to_string(kMaxVertices) + " vertices allowed"};
  }
  if (!(s.minTriangleQuality >= 0.0 && s.minTriangleQuality < 1.0)) {
    return Error{"mesh.min_quality must be in [0, 1), got " + numberText(s.minTriangleQuality)};
  }
  return Status::success();
}

Status validateMaterialKeys(const Scene& s) {
  if (Expected<Material> m = makeMaterial(s.materialModel, Lame{}); !m) {
    return Error{"material.model: " + m.error()};
  }
  if (Expected<Lame> lame = membraneLame(s); !lame) return Error{lame.error()};
  FEM_CLOTH_CHECK(inRange(s.thickness, 1e-6, 0.1, "material.thickness", "m"));
  FEM_CLOTH_CHECK(inRange(s.density, 1.0, 1e5, "material.density", "kg/m^3"));
  FEM_CLOTH_CHECK(inRange(s.bendingStiffness, 0.0, 1e4, "bending.stiffness", "N m"));
  if (!(s.bendingPoissonRatio >= 0.0 && s.bendingPoissonRatio < 0.5)) {
    return Error{"bending.poisson_ratio must be in [0, 0.5), got " + numberText(s.bendingPoissonRatio)};
  }
  FEM_CLOTH_CHECK(inRange(s.damping.massProportional, 0.0, 1e4, "damping.mass", "1/s"));
  FEM_CLOTH_CHECK(inRange(s.damping.stiffnessProportional, 0.0, 10.0, "damping.stiffness", "s"));
  return boundedVector(s.gravity, 1e3, "gravity", "m/s^2");
}

// The keys every integrator reads, then each registered integrator's own (registry.h), whatever
// the scene's integrator: a bad value is refused even while another integrator is chosen.
Status validateIntegratorKeys(const Scene& s) {
  if (Expected<const IntegratorEntry*> known = findIntegrator(s.integrator); !known) {
    return Error{"integrator.name: " + known.error()};
  }
  FEM_CLOTH_CHECK(inRange(s.dt, 1e-7, 100.0, "integrator.dt", "s"));
  FEM_CLOTH_CHECK(countInRange(s.substeps, 1, 1'000'000, "integrator.substeps"));
  FEM_CLOTH_CHECK(countInRange(s.maxRetries, 0, 20, "integrator.max_retries"));
  for (const IntegratorEntry& entry : integratorRegistry()) FEM_CLOTH_CHECK(entry.check(s));
  return Status::success();
}

Status validateAirKeys(const Scene& s) {
  if (!s.air) return Status::success();
  const int dim = meshDim(s);
  if (dim != 3) return Error{"air: the air model needs a cloth in 3D (mesh.dim 3), got dim " + std::to_string(dim)};
  FEM_CLOTH_CHECK(inRange(s.air->density, 0.0, 1e4, "air.density", "kg/m^3"));
  FEM_CLOTH_CHECK(inRange(s.air->normalDrag, 0.0, 10.0, "air.normal_drag", ""));
  FEM_CLOTH_CHECK(inRange(s.air->tangentialDrag, 0.0, 10.0, "air.tangential_drag", ""));
  return boundedVector(s.air->wind, 1e3, "air.wind", "m/s");
}

Status validateCommandKeys(const Scene& s) {
  for (std::size_t i = 0; i < s.pins.size(); ++i) {
    const std::string key = "pins[" + std::to_string(i) + "]";
    const ScenePin& p = s.pins[i];
    if (p.select.empty()) return Error{key + " selects no vertices"};
    FEM_CLOTH_CHECK(boundedVector(p.offset, kMaxCoordinate, key + ".offset", "m"));
    FEM_CLOTH_CHECK(boundedVector(p.velocity, kMaxSpeed, key + ".velocity", "m/s"));
    for (const auto& t : p.targets) FEM_CLOTH_CHECK(boundedPosition(t, key + ".targets"));
    FEM_CLOTH_CHECK(checkTrajectory(p.trajectory, key));
    if (!p.trajectory.empty() && !p.velocity.isZero()) {
      return Error{key + ": give velocity or trajectory, not both"};
    }
    if (!(p.releaseAt > 0.0)) return Error{key + ".release_at must be positive (s)"};
  }
  for (std::size_t i = 0; i < s.forces.size(); ++i) {
    const std::string key = "forces[" + std::to_string(i) + "]";
    const SceneForce& f = s.forces[i];
    if (f.select.empty()) return Error{key + " selects no vertices"};
    FEM_CLOTH_CHECK(boundedVector(f.force, 1e6, key + ".force", "N"));
    FEM_CLOTH_CHECK(inRange(f.start, 0.0, kMaxDuration, key + ".start", "s"));
    if (!(f.duration > 0.0)) return Error{key + ".duration must be positive (s)"};
  }
  for (std::size_t i = 0; i < s.initialPositions.size(); ++i) {
    FEM_CLOTH_CHECK(boundedPosition(s.initialPositions[i].position,
                                    "initial.positions[" + std::to_string(i) + "].position"));
  }
  return boundedVector(s.initialVelocity, kMaxSpeed, "initial.velocity", "m/s");
}

Status validateRunLength(const Scene& s) {
  FEM_CLOTH_CHECK(positiveUpTo(s.duration, kMaxDuration, "duration", "s"));
  return checkStepCount(s.duration, s.dt, s.substeps, "duration");
}

Status validateContactKeys(const Scene& s) {
  FEM_CLOTH_CHECK(inRange(s.contact.distance, 1e-6, 1.0, "contact.distance", "m"));
  FEM_CLOTH_CHECK(inRange(s.contact.stiffness, 0.0, 1e9, "contact.stiffness", "m/s^2"));
  FEM_CLOTH_CHECK(inRange(s.contact.frictionVelocity, 1e-8, 1.0, "contact.friction_velocity", "m/s"));
  FEM_CLOTH_CHECK(inRange(s.contact.surfaceStretch, 1.0, 10.0, "contact.surface_stretch", ""));
  if (s.contact.surfaceTolerance >= 0.0) {  // negative: auto (contact.distance)
    FEM_CLOTH_CHECK(inRange(s.contact.surfaceTolerance, 0.0, 1.0, "contact.surface_tolerance", "m"));
  }
  FEM_CLOTH_CHECK(inRange(s.contact.selfFriction, 0.0, kMaxFriction, "contact.self_friction", ""));
  if (sceneHasContact(s)) {
    if (meshDim(s) != 3) {
      return Error{s.obstacles.empty() ? "contact.self_collision needs a 3D cloth (mesh.dim 3)"
                                       : "obstacles need a 3D cloth (mesh.dim 3)"};
    }
  }
  std::set<std::string> names;
  for (std::size_t i = 0; i < s.obstacles.size(); ++i) {
    const std::string key = "obstacles[" + std::to_string(i) + "]";
    Expected<Obstacle> o = makeObstacle(s.obstacles[i], key);
    if (!o) return Error{o.error()};
    if (!names.insert(o->name).second) {
      return Error{key + ".name: another obstacle is already called '" + o->name + "'"};
    }
  }
  return Status::success();
}

}  // namespace

Status validateScene(const Scene& s) {
  FEM_CLOTH_CHECK(checkName(s.name));
  FEM_CLOTH_CHECK(validateMeshKeys(s));
  FEM_CLOTH_CHECK(validateMaterialKeys(s));
  FEM_CLOTH_CHECK(validateIntegratorKeys(s));
  FEM_CLOTH_CHECK(validateCommandKeys(s));
  FEM_CLOTH_CHECK(validateAirKeys(s));
  FEM_CLOTH_CHECK(validateRunLength(s));
  FEM_CLOTH_CHECK(validateContactKeys(s));
  // Last: what the integrator supports is asked of a scene whose every key is valid.
  return checkIntegratorSupports(s);
}

Expected<Obstacle> makeObstacle(const SceneObstacle& e, const std::string& key) {
  Obstacle o;
  o.name = e.name;
  o.shape.type = e.type;
  // Names appear in topic names: letters, digits and underscores, not starting with a digit.
  const bool nameOk = !o.name.empty() && !std::isdigit(static_cast<unsigned char>(o.name[0])) &&
                      std::all_of(o.name.begin(), o.name.end(), [](char c) {
                        return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
                      });
  if (!nameOk) {
    return Error{key + ".name must be letters, digits and underscores (not starting with a digit), "
                 "got '" + o.name + "'"};
  }
  FEM_CLOTH_CHECK(boundedPosition(e.center, key + ".center"));
  for (int k = 0; k < 3; ++k) {
    FEM_CLOTH_CHECK(inRange(e.orientation[k], -10.0, 10.0,
                            key + ".orientation[" + std::to_string(k) + "]", "rad"));
  }
  o.geometry.linear() = rotationFromRpy(e.orientation);
  o.geometry.translation() = e.center;
  FEM_CLOTH_CHECK(shapeEntry(e.type).make(e, key, o));
  FEM_CLOTH_CHECK(inRange(e.friction, 0.0, kMaxFriction, key + ".friction", ""));
  o.friction = e.friction;
  o.frame = e.frame;
  FEM_CLOTH_CHECK(boundedVector(e.velocity, kMaxSpeed, key + ".velocity", "m/s"));
  o.velocity = e.velocity;
  FEM_CLOTH_CHECK(checkTrajectory(e.trajectory, key));
  o.trajectory = e.trajectory;
  if (!o.velocity.isZero() && !o.trajectory.empty()) {
    return Error{key + ": give velocity or trajectory, not both"};
  }
  if (!o.frame.empty() && o.scripted()) {
    return Error{key + ": an obstacle that follows frame '" + o.frame +
                 "' cannot have a velocity or trajectory as well"};
  }
  return o;
}

Expected<Lame> membraneLame(const Scene& s) {
  const bool young = s.youngsModulus.has_value() || s.poissonRatio.has_value();
  const bool lame = s.mu.has_value() || s.lambda.has_value();
  if (young && lame) {
    return Error{"material: give either youngs_modulus and poisson_ratio, or mu and lambda, "
                 "not both"};
  }
  if (!young && !lame) {
    return Error{"material: youngs_modulus and poisson_ratio (or mu and lambda) are required"};
  }
  Lame volumetric;
  if (young) {
    if (!s.youngsModulus) return Error{"material.youngs_modulus is required with poisson_ratio"};
    if (!s.poissonRatio) return Error{"material.poisson_ratio is required with youngs_modulus"};
    FEM_CLOTH_CHECK(inRange(*s.youngsModulus, kMinModulus, kMaxModulus, "material.youngs_modulus", "Pa"));
    if (!(*s.poissonRatio >= 0.0 && *s.poissonRatio < 0.5)) {
      return Error{"material.poisson_ratio must be in [0, 0.5), got " + numberText(*s.poissonRatio)};
    }
    volumetric = Lame::fromYoungPoisson(*s.youngsModulus, *s.poissonRatio);
  } else {
    if (!s.mu || !s.lambda) return Error{"material: mu and lambda must be given together"};
    FEM_CLOTH_CHECK(inRange(*s.mu, kMinModulus, kMaxModulus, "material.mu", "Pa"));
    FEM_CLOTH_CHECK(inRange(*s.lambda, 0.0, kMaxModulus, "material.lambda", "Pa"));
    volumetric = Lame{*s.mu, *s.lambda};
  }
  return Lame{volumetric.mu * s.thickness, volumetric.lambda * s.thickness};
}

void SceneScript::add(const Event& event) {
  auto it = std::upper_bound(events_.begin(), events_.end(), event,
                             [](const Event& a, const Event& b) { return a.time < b.time; });
  events_.insert(it, event);
}

Status SceneScript::applyDue(Simulator& sim) {
  const double now = sim.time() + 1e-9 * sim.settings().dt;
  while (next_ < events_.size() && events_[next_].time <= now) {
    const Event& e = events_[next_++];
    Status s;
    switch (e.kind) {
      case Event::Kind::ReleasePin: s = sim.release(e.vertex); break;
      case Event::Kind::ApplyForce: s = sim.applyForce(e.vertex, e.force, e.duration); break;
      case Event::Kind::PinVelocity:
        // A pin released earlier stays released.
        if (sim.isPinned(e.vertex)) s = sim.pin(e.vertex, sim.pinTarget(e.vertex), e.velocity);
        break;
    }
    if (!s) return s;
  }
  return Status::success();
}

Expected<std::vector<char>> heldVertices(const Scene& scene, Index numVertices) {
  std::vector<char> held(static_cast<std::size_t>(numVertices), 0);
  for (std::size_t i = 0; i < scene.pins.size(); ++i) {
    if (std::isfinite(scene.pins[i].releaseAt)) continue;
    Expected<std::vector<Index>> verts =
        resolveSelection(scene.pins[i].select, scene, numVertices, "pins[" + std::to_string(i) + "]");
    if (!verts) return Error{verts.error()};
    for (Index v : *verts) held[static_cast<std::size_t>(v)] = 1;
  }
  return held;
}

Status checkStepCount(double duration, double dt, int substeps, const std::string& what) {
  const double steps = std::ceil(duration / dt - 1e-9) * substeps;
  if (!(steps <= static_cast<double>(kMaxSteps))) {
    // Whole numbers as such while they are exact in a double (2^53).
    const std::string count = steps < 9e15 ? std::to_string(static_cast<long long>(steps)) : numberText(steps);
    return Error{what + ": " + numberText(duration) + " s at integrator.dt " + numberText(dt) +
                 " s and " + std::to_string(substeps) + " substeps needs " + count + " steps, more than the " +
                 std::to_string(kMaxSteps) + " allowed; shorten the duration or take larger steps"};
  }
  return Status::success();
}

std::string meshFilePath(const Scene& s) {
  if (s.meshType != MeshType::Obj) return "";
  std::string path = s.objFile;
  if (!path.empty() && path[0] != '/' && !s.sourcePath.empty()) {
    const auto slash = s.sourcePath.find_last_of('/');
    if (slash != std::string::npos) path = s.sourcePath.substr(0, slash + 1) + path;
  }
  return path;
}

Expected<std::vector<Index>> resolveSelection(const VertexSelection& sel, const Scene& scene,
                                              Index numVertices, const std::string& key) {
  std::vector<Index> out;
  for (Index v : sel.vertices) {
    if (v < 0 || v >= numVertices) {
      return Error{key + ": vertex " + std::to_string(v) + " does not exist (the mesh has " +
                   std::to_string(numVertices) + " vertices)"};
    }
    out.push_back(v);
  }
  const bool gridForms = !sel.gridVertices.empty() || !sel.gridEdge.empty();
  if (gridForms && scene.meshType != MeshType::Grid) {
    return Error{key + ": grid_vertices and grid_edge need mesh.type grid"};
  }
  const int rows = scene.grid.rows, cols = scene.grid.cols;
  for (const auto& rc : sel.gridVertices) {
    const int r = rc[0] < 0 ? rows + rc[0] : rc[0];
    const int c = rc[1] < 0 ? cols + rc[1] : rc[1];
    if (r < 0 || r >= rows || c < 0 || c >= cols) {
      return Error{key + ": grid vertex (" + std::to_string(rc[0]) + ", " + std::to_string(rc[1]) +
                   ") is outside the " + std::to_string(rows) + " x " + std::to_string(cols) +
                   " grid"};
    }
    out.push_back(r * cols + c);
  }
  if (!sel.gridEdge.empty()) {
    if (sel.gridEdge == "first_row" || sel.gridEdge == "last_row") {
      const int r = sel.gridEdge == "first_row" ? 0 : rows - 1;
      for (int c = 0; c < cols; ++c) out.push_back(r * cols + c);
    } else if (sel.gridEdge == "first_col" || sel.gridEdge == "last_col") {
      const int c = sel.gridEdge == "first_col" ? 0 : cols - 1;
      for (int r = 0; r < rows; ++r) out.push_back(r * cols + c);
    } else if (sel.gridEdge == "all") {
      for (Index v = 0; v < numVertices; ++v) out.push_back(v);
    } else {
      return Error{key + ".grid_edge must be first_row, last_row, first_col, last_col or all, got '" +
                   sel.gridEdge + "'"};
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

Expected<Mesh> buildMesh(const Scene& s) {
  if (s.meshType == MeshType::Grid) return makeGrid(s.grid);
  if (s.meshType == MeshType::Obj) return loadObj(meshFilePath(s), s.dim);
  Mesh mesh = s.explicitMesh;
  mesh.dim = s.dim;
  return mesh;
}

namespace {

// The contact distance dHat is a gap the cloth keeps from obstacles and from itself: one larger
// than the mesh's shortest edge keeps the cloth floating coarser than it is resolved, and with
// self-collision pushes apart vertices that are neighbours at rest.
Status checkContactDistance(const Mesh& mesh, double distance) {
  double shortest = std::numeric_limits<double>::infinity();
  std::array<Index, 2> which{};
  const int d = mesh.dim;
  for (const auto& e : uniqueEdges(mesh.triangles)) {
    const double length =
        (mesh.restPositions.segment(d * e[1], d) - mesh.restPositions.segment(d * e[0], d)).norm();
    if (length < shortest) {
      shortest = length;
      which = e;
    }
  }
  if (distance >= shortest) {
    return Error{"contact.distance (" + numberText(distance) + " m) must be smaller than the "
                 "shortest rest edge of the mesh (" + numberText(shortest) + " m, between vertices " +
                 std::to_string(which[0]) + " and " + std::to_string(which[1]) +
                 "); use a smaller distance or a coarser mesh"};
  }
  return Status::success();
}

// An OBJ or explicit mesh gives its own coordinates: within the same bounds as a grid's.
Status checkMeshExtent(const Mesh& mesh) {
  const int d = mesh.dim;
  for (Index i = 0; i < mesh.numVertices(); ++i) {
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    p.head(d) = mesh.restPositions.segment(d * i, d);
    FEM_CLOTH_CHECK(boundedPosition(p, "vertex " + std::to_string(i)));
  }
  const double size = restBoundingBoxDiagonal(mesh);
  if (!(size >= kMinClothSize)) {
    return Error{"the cloth is " + numberText(size) + " m across (its rest bounding box diagonal), "
                 "less than the " + numberText(kMinClothSize) + " m allowed"};
  }
  return Status::success();
}


// The integrators whose contact is the barriers, "backward_euler, bdf2".
std::string barrierIntegrators() {
  std::vector<std::string> names;
  for (const IntegratorEntry& e : integratorRegistry()) {
    if (e.supports.contact == ContactMethod::Barriers) names.push_back(e.name);
  }
  return commaList(names);
}

// Every free vertex starts outside the obstacles, no closer than dHat/2, and for the explicit
// steppers' projection no closer than dHat (those that follow a tf frame are placed only when
// the node runs).
Status checkObstacleGaps(const Scene& scene, const ObstacleSet& obstacles, const VectorX& x,
                         const std::vector<Index>& pinned) {
  const bool projection = (*findIntegrator(scene.integrator))->supports.contact == ContactMethod::Projection;
  const Index n = static_cast<Index>(x.size() / 3);
  std::vector<char> isPinned(static_cast<std::size_t>(n), 0);
  for (Index vert : pinned) isPinned[static_cast<std::size_t>(vert)] = 1;
  for (std::size_t k = 0; k < scene.obstacles.size(); ++k) {
    if (!obstacles[k].frame.empty()) continue;
    const std::string name = "obstacles[" + std::to_string(k) + "] ('" + obstacles[k].name + "')";
    for (Index vert = 0; vert < n; ++vert) {
      if (isPinned[static_cast<std::size_t>(vert)]) continue;
      const double dist = signedDistance(obstacles[k].shape,
                                         obstacles.shapePose(k).inverse() * Eigen::Vector3d(x.segment<3>(3 * vert)))
                              .distance;
      if (!(dist > 0.0)) {
        return Error{name + ": vertex " + std::to_string(vert) + " starts inside it or on its surface (distance " +
                     numberText(dist) + " m); move the obstacle or the cloth"};
      }
      // The automatic barrier stiffness holds a cloth resting under its weight at about dHat/2
      // (contact_model.h), so a cloth may start resting there; much closer, the barrier (or the
      // explicit steppers' projection to dHat) throws the vertex out in the first step.
      if (dist < 0.5 * scene.contact.distance * (1.0 - 1e-9)) {
        return Error{"contact.distance (" + numberText(scene.contact.distance) +
                     " m) is more than twice the gap at which vertex " + std::to_string(vert) +
                     " starts from " + name + " (" + numberText(dist) +
                     " m; a resting cloth keeps about half the distance); use a smaller distance "
                     "or start the cloth farther away"};
      }
      // Issue 30: the projection moves a vertex out to dHat in the first substep, and the move
      // becomes velocity (config/gripper_pinch.yaml, 1.6 mm above its table, put 172 J into a
      // 0.085 J cloth with symplectic Euler): refused here, before step 1.
      if (projection && dist < scene.contact.distance) {
        return Error{name + ": vertex " + std::to_string(vert) + " starts " + numberText(dist) +
                     " m from it, within contact.distance (" + numberText(scene.contact.distance) +
                     " m), where integrator " + scene.integrator + "'s projection would throw it out in "
                     "the first step; start the cloth at least contact.distance away, or choose an "
                     "integrator whose barriers hold it there: " + barrierIntegrators()};
      }
    }
  }
  return Status::success();
}

// With self-collision the cloth must start free of crossings and of contacts with itself.
Status checkSelfContactAtStart(const Scene& scene, ContactModel& contact, const Mesh& mesh,
                               const VectorX& x) {
  // Parts of the cloth that share no vertex must be farther apart than dHat at rest, or the
  // barrier would push them apart from the start.
  const double rest = contact.minimumSelfDistance(mesh.restPositions);
  if (rest < scene.contact.distance) {
    return Error{"contact.distance (" + numberText(scene.contact.distance) +
                 " m) must be below the smallest rest distance between parts of the cloth that "
                 "share no vertex (" + numberText(rest) + " m) for self_collision; use a smaller distance "
                 "or a coarser mesh"};
  }
  auto crossing = [&mesh](const std::optional<SelfIntersection>& hit) {
    return "edge (" + std::to_string(hit->edge[0]) + ", " + std::to_string(hit->edge[1]) +
           ") of triangle " + std::to_string(hit->edgeTriangle) + " passes through triangle " +
           std::to_string(hit->triangle) + " (" + std::to_string(mesh.triangles[hit->triangle][0]) + ", " +
           std::to_string(mesh.triangles[hit->triangle][1]) + ", " +
           std::to_string(mesh.triangles[hit->triangle][2]) + ")";
  };
  if (auto hit = findSelfIntersection(mesh, mesh.restPositions)) {
    return Error{"mesh: the rest mesh intersects itself: " + crossing(hit) +
                 "; self_collision needs a cloth that does not pass through itself"};
  }
  if (x != mesh.restPositions) {
    if (auto hit = findSelfIntersection(mesh, x)) {
      return Error{"initial: the initial positions intersect themselves: " + crossing(hit) +
                   "; self_collision needs a cloth that does not pass through itself"};
    }
  }
  if (!(contact.minimumSelfDistance(x) > 0.0)) {
    return Error{"initial: the cloth starts intersecting itself (with self_collision on)"};
  }
  return Status::success();
}

// The scene's obstacles, and the one contact method its integrator uses on them. checkStart:
// check them against the initial state x (a live change checks the running state instead).
Status addContact(const Scene& scene, const Model& model, const VectorX& x,
                  const std::vector<Index>& pinned, Simulator& simulator, bool checkStart) {
  FEM_CLOTH_CHECK(checkContactDistance(model.mesh(), scene.contact.distance));
  std::vector<Obstacle> list;
  for (std::size_t i = 0; i < scene.obstacles.size(); ++i) {
    list.push_back(*makeObstacle(scene.obstacles[i], "obstacles[" + std::to_string(i) + "]"));
  }
  auto obstacles = std::make_shared<ObstacleSet>(std::move(list));
  if (checkStart) FEM_CLOTH_CHECK(checkObstacleGaps(scene, *obstacles, x, pinned));
  switch ((*findIntegrator(scene.integrator))->supports.contact) {
    case ContactMethod::Barriers: {
      auto barriers = std::make_unique<ContactModel>(model, obstacles, scene.contact, scene.gravity.norm());
      if (checkStart) {
        FEM_CLOTH_CHECK(barriers->checkSurfaceAtStart(x, pinned));
        if (scene.contact.selfCollision) FEM_CLOTH_CHECK(checkSelfContactAtStart(scene, *barriers, model.mesh(), x));
      }
      simulator.setContact(obstacles, std::move(barriers));
      break;
    }
    case ContactMethod::Projection:
      simulator.setContact(obstacles, nullptr,
                           std::make_unique<ProjectionContact>(model, obstacles, scene.contact));
      break;
    case ContactMethod::None:  // validateScene refused the scene's contact (checkIntegratorSupports)
      return Error{"integrator.name: " + scene.integrator + " handles no contact"};
  }
  return Status::success();
}
}  // namespace

namespace {

// The scene's mesh, built and checked (mesh warnings into `warnings`).
Expected<std::shared_ptr<const Mesh>> checkedMesh(const Scene& scene, std::vector<std::string>& warnings) {
  Expected<Mesh> built = buildMesh(scene);
  if (!built) return Error{(scene.meshType == MeshType::Obj ? "mesh.file: " : "mesh: ") + built.error()};
  const MeshValidation check = validateMesh(*built, scene.minTriangleQuality);
  if (!check.ok()) return Error{"mesh: " + check.errorSummary()};
  if (scene.meshType != MeshType::Grid) {
    if (Status st = checkMeshExtent(*built); !st) return Error{"mesh: " + st.error()};
  }
  warnings = check.warnings;
  return std::make_shared<const Mesh>(std::move(built).value());
}

// The energy terms the scene declares: the membrane, and bending when its stiffness is not zero.
Status addEnergyTerms(const Scene& scene, const std::shared_ptr<const Mesh>& mesh,
                      const std::shared_ptr<const RestState>& rest, const Material& material,
                      Model& model) {
  model.addTerm(makeMembraneTerm(mesh, rest, material), TermKind::Membrane);
  // Zero stiffness declares no bending term at all, so planar meshes (which cannot bend) build;
  // a planar mesh with a non-zero stiffness is an error naming the key.
  if (scene.bendingStiffness > 0.0) {
    BendingSpec spec;
    spec.model = scene.bendingModel;
    spec.stiffness = scene.bendingStiffness;
    spec.poissonRatio = scene.bendingPoissonRatio;
    if (spec.model == BendingModel::Midedge) {
      Expected<std::vector<char>> held = heldVertices(scene, mesh->numVertices());
      if (!held) return Error{held.error()};
      spec.held = std::move(held).value();
    }
    Expected<std::unique_ptr<EnergyTerm>> bending = makeBendingTerm(*mesh, *rest, spec);
    if (!bending) return Error{"bending.stiffness: " + bending.error()};
    model.addTerm(std::move(bending).value(), TermKind::Bending);
  }
  return Status::success();
}

// Initial positions and velocities before the pins place their vertices.
Status initialState(const Scene& scene, const Mesh& mesh, VectorX& x, VectorX& v) {
  const int d = mesh.dim;
  const Index n = mesh.numVertices();
  x = mesh.restPositions;
  for (const auto& p : scene.initialPositions) {
    if (p.vertex < 0 || p.vertex >= n) {
      return Error{"initial.positions: vertex " + std::to_string(p.vertex) +
                   " does not exist (the mesh has " + std::to_string(n) + " vertices)"};
    }
    x.segment(d * p.vertex, d) = p.position.head(d);
  }
  v = VectorX::Zero(x.size());
  for (Index i = 0; i < n; ++i) v.segment(d * i, d) = scene.initialVelocity.head(d);
  return Status::success();
}

// A trajectory is followed as a velocity that changes at its waypoints: exact when the
// waypoint times fall on step boundaries. Moves `target` to the first waypoint, sets the
// velocity from time 0 and scripts the later changes of vertex `vert`.
void followTrajectory(const std::vector<TrajectoryPoint>& w, Index vert, Eigen::Vector3d& target,
                      Eigen::Vector3d& velocity, SceneScript& script) {
  target += w.front().offset;
  for (std::size_t j = 0; j < w.size(); ++j) {
    // From waypoint j on, towards waypoint j + 1 (after the last one: at rest).
    const Eigen::Vector3d slope =
        j + 1 == w.size() ? Eigen::Vector3d::Zero()
                          : Eigen::Vector3d((w[j + 1].offset - w[j].offset) / (w[j + 1].time - w[j].time));
    if (w[j].time <= 0.0) {
      velocity = slope;
      continue;
    }
    SceneScript::Event e;
    e.time = w[j].time;
    e.kind = SceneScript::Event::Kind::PinVelocity;
    e.vertex = vert;
    e.velocity = slope;
    script.add(e);
  }
}

// Pins (targets from the initial positions x, which they move to the targets) and their
// scripted motion and releases.
Status applyScenePins(const Scene& scene, Simulator& simulator, SceneScript& script, VectorX& x,
                      VectorX& v) {
  const int d = simulator.model().dim();
  const Index n = simulator.model().numVertices();
  for (std::size_t i = 0; i < scene.pins.size(); ++i) {
    const ScenePin& p = scene.pins[i];
    const std::string key = "pins[" + std::to_string(i) + "]";
    Expected<std::vector<Index>> verts = resolveSelection(p.select, scene, n, key);
    if (!verts) return Error{verts.error()};
    if (!p.targets.empty() && p.targets.size() != verts->size()) {
      return Error{key + ".targets has " + std::to_string(p.targets.size()) +
                   " entries for " + std::to_string(verts->size()) + " selected vertices"};
    }
    for (std::size_t k = 0; k < verts->size(); ++k) {
      const Index vert = (*verts)[k];
      Eigen::Vector3d target = Eigen::Vector3d::Zero();
      if (!p.targets.empty()) {
        target = p.targets[k];
      } else {
        target.head(d) = x.segment(d * vert, d);
        target += p.offset;
      }
      Eigen::Vector3d velocity = p.velocity;
      if (!p.trajectory.empty()) followTrajectory(p.trajectory, vert, target, velocity, script);
      x.segment(d * vert, d) = target.head(d);
      v.segment(d * vert, d) = velocity.head(d);
      if (Status st = simulator.pin(vert, target, velocity); !st) return Error{key + ": " + st.error()};
      if (std::isfinite(p.releaseAt)) {
        SceneScript::Event e;
        e.time = p.releaseAt;
        e.kind = SceneScript::Event::Kind::ReleasePin;
        e.vertex = vert;
        script.add(e);
      }
    }
  }
  return Status::success();
}

// Forces: applied now when they start at 0, scripted otherwise.
Status applySceneForces(const Scene& scene, Simulator& simulator, SceneScript& script) {
  const Index n = simulator.model().numVertices();
  for (std::size_t i = 0; i < scene.forces.size(); ++i) {
    const SceneForce& f = scene.forces[i];
    const std::string key = "forces[" + std::to_string(i) + "]";
    Expected<std::vector<Index>> verts = resolveSelection(f.select, scene, n, key);
    if (!verts) return Error{verts.error()};
    for (Index vert : *verts) {
      if (f.start <= 0.0) {
        if (Status st = simulator.applyForce(vert, f.force, f.duration); !st) {
          return Error{key + ": " + st.error()};
        }
      } else {
        SceneScript::Event e;
        e.time = f.start;
        e.kind = SceneScript::Event::Kind::ApplyForce;
        e.vertex = vert;
        e.force = f.force;
        e.duration = f.duration;
        script.add(e);
      }
    }
  }
  return Status::success();
}

}  // namespace

SimulatorSettings simulatorSettings(const Scene& scene) {
  SimulatorSettings settings;
  settings.gravity = scene.gravity;
  settings.damping = scene.damping;
  settings.dt = scene.dt;
  settings.minSubsteps = scene.substeps;
  settings.maxRetries = scene.maxRetries;
  settings.acceptance.displacement = scene.displacement;
  return settings;
}

namespace {

Expected<Simulation> build(const Scene& scene, bool checkStart) {
  if (Status s = validateScene(scene); !s) return Error{s.error()};
  Simulation sim;
  Expected<std::shared_ptr<const Mesh>> checked = checkedMesh(scene, sim.warnings);
  if (!checked) return Error{checked.error()};
  const std::shared_ptr<const Mesh> mesh = *checked;
  Expected<RestState> restState = computeRestState(*mesh);
  if (!restState) return Error{"mesh: " + restState.error()};
  auto rest = std::make_shared<const RestState>(std::move(restState).value());
  const Lame lame = *membraneLame(scene);
  Expected<Material> material = makeMaterial(scene.materialModel, lame);
  if (!material) return Error{"material.model: " + material.error()};

  sim.mesh = mesh;
  sim.model = std::make_shared<Model>(mesh, rest,
                                       lumpedMasses(*mesh, *rest, scene.density * scene.thickness));
  FEM_CLOTH_CHECK(addEnergyTerms(scene, mesh, rest, *material, *sim.model));

  sim.simulator = std::make_unique<Simulator>(sim.model, (*findIntegrator(scene.integrator))->make(scene),
                                              simulatorSettings(scene));
  if (scene.air) sim.simulator->setAir(std::make_unique<AirModel>(mesh, *scene.air));
  Simulator& simulator = *sim.simulator;

  VectorX x, v;
  FEM_CLOTH_CHECK(initialState(scene, *mesh, x, v));
  FEM_CLOTH_CHECK(applyScenePins(scene, simulator, sim.script, x, v));
  FEM_CLOTH_CHECK(applySceneForces(scene, simulator, sim.script));
  if (Status st = simulator.setInitialState(x, v); !st) return Error{"initial: " + st.error()};
  if (sceneHasContact(scene)) {
    FEM_CLOTH_CHECK(addContact(scene, *sim.model, x, simulator.pinnedVertices(), simulator, checkStart));
  }
  const Model::Energies e0 = sim.model->energies(x);
  if (!std::isfinite(e0.total())) {
    return Error{"initial: the initial positions put an element outside the material's domain "
                 "(J <= 0 for " + scene.materialModel + ")"};
  }
  return sim;
}

}  // namespace

Expected<Simulation> buildSimulation(const Scene& scene) { return build(scene, true); }

Expected<Simulation> buildSimulationToContinue(const Scene& scene) { return build(scene, false); }

}  // namespace fem_cloth
