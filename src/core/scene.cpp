#include "fem_cloth/core/scene.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <set>
#include <sstream>

#include "fem_cloth/core/bending.h"
#include "fem_cloth/core/membrane.h"

namespace fem_cloth {

namespace {

Status positiveFinite(double value, const std::string& key, const std::string& unit) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    return Error{key + " must be positive and finite (" + unit + "), got " + numberText(value)};
  }
  return Status::success();
}

Status nonNegativeFinite(double value, const std::string& key, const std::string& unit) {
  if (!(value >= 0.0) || !std::isfinite(value)) {
    return Error{key + " must be zero or positive and finite (" + unit + "), got " + numberText(value)};
  }
  return Status::success();
}

Status finiteVector(const Eigen::Vector3d& v, const std::string& key) {
  if (!v.allFinite()) return Error{key + " must be finite"};
  return Status::success();
}

Status checkTrajectory(const std::vector<TrajectoryPoint>& trajectory, const std::string& key) {
  for (std::size_t k = 0; k < trajectory.size(); ++k) {
    const std::string at = key + ".trajectory[" + std::to_string(k) + "]";
    if (Status s = nonNegativeFinite(trajectory[k].time, at + ".time", "s"); !s) return s;
    if (Status s = finiteVector(trajectory[k].offset, at + ".offset"); !s) return s;
    if (k > 0 && !(trajectory[k].time > trajectory[k - 1].time)) {
      return Error{at + ".time must be later than the point before (" +
                   numberText(trajectory[k - 1].time) + " s), got " + numberText(trajectory[k].time)};
    }
  }
  return Status::success();
}

#define FEM_CLOTH_CHECK(expr)     \
  do {                            \
    if (Status check_ = (expr); !check_) { \
      return Error{check_.error()}; \
    }                             \
  } while (false)

}  // namespace

const std::vector<std::string>& integratorNames() {
  static const std::vector<std::string> names = {"symplectic_euler", "backward_euler", "bdf2",
                                                 "xpbd", "projective_dynamics"};
  return names;
}

Status validateScene(const Scene& s) {
  if (s.meshType == "grid") {
    if (s.grid.rows < 2) return Error{"mesh.rows must be at least 2, got " + std::to_string(s.grid.rows)};
    if (s.grid.cols < 2) return Error{"mesh.cols must be at least 2, got " + std::to_string(s.grid.cols)};
    FEM_CLOTH_CHECK(positiveFinite(s.grid.width, "mesh.width", "m"));
    FEM_CLOTH_CHECK(positiveFinite(s.grid.height, "mesh.height", "m"));
    if (s.grid.dim != 2 && s.grid.dim != 3) {
      return Error{"mesh.dim must be 2 or 3, got " + std::to_string(s.grid.dim)};
    }
  } else if (s.meshType == "obj") {
    if (s.objFile.empty()) return Error{"mesh.file is required for mesh.type obj"};
  } else if (s.meshType != "explicit") {
    return Error{"mesh.type must be grid, obj or explicit, got '" + s.meshType + "'"};
  }
  if ((s.meshType != "grid") && s.dim != 2 && s.dim != 3) {
    return Error{"mesh.dim must be 2 or 3, got " + std::to_string(s.dim)};
  }
  if (!(s.minTriangleQuality >= 0.0 && s.minTriangleQuality < 1.0)) {
    return Error{"mesh.min_quality must be in [0, 1), got " + numberText(s.minTriangleQuality)};
  }
  if (Expected<Material> m = makeMaterial(s.materialModel, Lame{}); !m) {
    return Error{"material.model: " + m.error()};
  }
  if (Expected<Lame> lame = membraneLame(s); !lame) return Error{lame.error()};
  FEM_CLOTH_CHECK(positiveFinite(s.thickness, "material.thickness", "m"));
  FEM_CLOTH_CHECK(positiveFinite(s.density, "material.density", "kg/m^3"));
  FEM_CLOTH_CHECK(nonNegativeFinite(s.bendingStiffness, "bending.stiffness", "N m"));
  if (std::find(bendingModelNames().begin(), bendingModelNames().end(), s.bendingModel) ==
      bendingModelNames().end()) {
    return Error{"bending.model must be midedge, quadratic or dihedral, got '" + s.bendingModel + "'"};
  }
  if (!(s.bendingPoissonRatio >= 0.0 && s.bendingPoissonRatio < 0.5)) {
    return Error{"bending.poisson_ratio must be in [0, 0.5), got " + numberText(s.bendingPoissonRatio)};
  }
  if (s.integrator == "xpbd" && s.bendingStiffness > 0.0 && s.bendingModel == "midedge") {
    // XPBD visits elements as constraints of at most 3 values on 4 vertices; a mid-edge element
    // reads 12 vertices. Said when the scene is loaded rather than at the first step.
    return Error{"bending.model: xpbd needs a bending model with a constraint form, quadratic or "
                 "dihedral, got 'midedge' (the default; set bending.model)"};
  }
  FEM_CLOTH_CHECK(nonNegativeFinite(s.damping.massProportional, "damping.mass", "1/s"));
  FEM_CLOTH_CHECK(nonNegativeFinite(s.damping.stiffnessProportional, "damping.stiffness", "s"));
  FEM_CLOTH_CHECK(finiteVector(s.gravity, "gravity"));
  if (std::find(integratorNames().begin(), integratorNames().end(), s.integrator) ==
      integratorNames().end()) {
    return Error{"integrator.name: unknown integrator '" + s.integrator +
                 "' (known: symplectic_euler, backward_euler, bdf2, xpbd, projective_dynamics)"};
  }
  if (s.integrator == "projective_dynamics") {
    // Projective dynamics needs every energy term in the form w/2 |A x - p(x)|^2 with a constant
    // A (Bouaziz et al. 2014, sec. 3); here that is the ARAP membrane and quadratic bending on
    // cloth. Say so when the scene is loaded rather than at the first step.
    if (s.materialModel != "arap") {
      return Error{"material.model: projective_dynamics simulates the arap membrane only, got '" +
                   s.materialModel + "' (use material.model: arap, or another integrator)"};
    }
    const int dim = s.meshType == "grid" ? s.grid.dim : s.dim;
    if (dim != 3) {
      return Error{"mesh.dim: projective_dynamics simulates cloth (dim 3) only"};
    }
    if (s.bendingStiffness > 0.0 && s.bendingModel != "quadratic") {
      return Error{"bending.model: projective_dynamics needs the quadratic bending model, got '" +
                   s.bendingModel + "'" + (s.bendingModel == "midedge" ? " (the default; set bending.model: quadratic)" : "")};
    }
    if (s.damping.stiffnessProportional > 0.0) {
      return Error{"damping.stiffness: projective_dynamics has no stiffness damping; set it to 0 "
                   "and use damping.mass"};
    }
  }
  FEM_CLOTH_CHECK(positiveFinite(s.dt, "integrator.dt", "s"));
  if (s.substeps < 1) return Error{"integrator.substeps must be at least 1, got " + std::to_string(s.substeps)};
  if (s.maxRetries < 0) return Error{"integrator.max_retries must be >= 0"};
  if (!(s.cflSafety > 0.0 && s.cflSafety <= 1.0)) {
    return Error{"integrator.cfl_safety must be in (0, 1], got " + numberText(s.cflSafety)};
  }
  if (s.newton.maxIterations < 1) return Error{"integrator.max_newton_iterations must be at least 1"};
  FEM_CLOTH_CHECK(positiveFinite(s.newton.tolerance, "integrator.newton_tolerance", "relative"));
  if (s.newton.maxBacktracks < 0) return Error{"integrator.max_backtracks must be >= 0"};
  FEM_CLOTH_CHECK(positiveFinite(s.newton.linear.cgTolerance, "integrator.cg_tolerance", "relative"));
  if (s.iterations < 1) return Error{"integrator.iterations must be at least 1"};
  if (!(s.chebyshevRho >= 0.0 && s.chebyshevRho < 1.0)) {
    return Error{"integrator.chebyshev_rho must be in [0, 1), got " + numberText(s.chebyshevRho)};
  }
  for (std::size_t i = 0; i < s.pins.size(); ++i) {
    const std::string key = "pins[" + std::to_string(i) + "]";
    const ScenePin& p = s.pins[i];
    if (p.select.empty()) return Error{key + " selects no vertices"};
    FEM_CLOTH_CHECK(finiteVector(p.offset, key + ".offset"));
    FEM_CLOTH_CHECK(finiteVector(p.velocity, key + ".velocity"));
    for (const auto& t : p.targets) FEM_CLOTH_CHECK(finiteVector(t, key + ".targets"));
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
    FEM_CLOTH_CHECK(finiteVector(f.force, key + ".force"));
    FEM_CLOTH_CHECK(nonNegativeFinite(f.start, key + ".start", "s"));
    if (!(f.duration > 0.0)) return Error{key + ".duration must be positive (s)"};
  }
  for (const auto& p : s.initialPositions) {
    FEM_CLOTH_CHECK(finiteVector(p.position, "initial.positions"));
  }
  FEM_CLOTH_CHECK(finiteVector(s.initialVelocity, "initial.velocity"));
  FEM_CLOTH_CHECK(positiveFinite(s.duration, "duration", "s"));
  // Contact.
  FEM_CLOTH_CHECK(positiveFinite(s.contact.distance, "contact.distance", "m"));
  FEM_CLOTH_CHECK(nonNegativeFinite(s.contact.stiffness, "contact.stiffness", "m/s^2"));
  FEM_CLOTH_CHECK(positiveFinite(s.contact.frictionVelocity, "contact.friction_velocity", "m/s"));
  FEM_CLOTH_CHECK(nonNegativeFinite(s.contact.selfFriction, "contact.self_friction", "dimensionless"));
  if (sceneHasContact(s)) {
    const int dim = s.meshType == "grid" ? s.grid.dim : s.dim;
    if (dim != 3) {
      return Error{s.obstacles.empty() ? "contact.self_collision needs a 3D cloth (mesh.dim 3)"
                                       : "obstacles need a 3D cloth (mesh.dim 3)"};
    }
  }
  if (s.contact.selfCollision && s.integrator != "backward_euler" && s.integrator != "bdf2") {
    return Error{"contact.self_collision needs an implicit integrator (backward_euler or bdf2), "
                 "not " + s.integrator};
  }
  if (!s.obstacles.empty() && s.integrator == "projective_dynamics") {
    // Its constant, prefactored system (Bouaziz et al. 2014) has no place for a barrier whose
    // Hessian changes with the contacts, and a projection after its global step would undo the
    // convergence it is chosen for; refused rather than silently ignoring the obstacles.
    return Error{"obstacles: projective_dynamics does not handle contact; use backward_euler, bdf2, "
                 "symplectic_euler or xpbd as integrator.name, or remove the obstacles"};
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

Expected<Obstacle> makeObstacle(const SceneObstacle& e, const std::string& key) {
  Obstacle o;
  o.name = e.name;
  const auto& names = shapeTypeNames();
  const auto type = std::find(names.begin(), names.end(), e.type);
  if (type == names.end()) {
    return Error{key + ".type must be plane, sphere, box or capsule, got '" + e.type + "'"};
  }
  o.shape.type = static_cast<ShapeType>(type - names.begin());
  // Names appear in topic names: letters, digits and underscores, not starting with a digit.
  const bool nameOk = !o.name.empty() && !std::isdigit(static_cast<unsigned char>(o.name[0])) &&
                      std::all_of(o.name.begin(), o.name.end(), [](char c) {
                        return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
                      });
  if (!nameOk) {
    return Error{key + ".name must be letters, digits and underscores (not starting with a digit), "
                 "got '" + o.name + "'"};
  }
  FEM_CLOTH_CHECK(finiteVector(e.center, key + ".center"));
  FEM_CLOTH_CHECK(finiteVector(e.orientation, key + ".orientation"));
  o.geometry.linear() = rotationFromRpy(e.orientation);
  o.geometry.translation() = e.center;
  switch (o.shape.type) {
    case ShapeType::Plane: {
      FEM_CLOTH_CHECK(finiteVector(e.point, key + ".point"));
      FEM_CLOTH_CHECK(finiteVector(e.normal, key + ".normal"));
      if (!(e.normal.norm() > 0.0)) return Error{key + ".normal must not be zero"};
      // The shape frame's z axis along the normal.
      o.geometry.linear() =
          Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), e.normal.normalized()).toRotationMatrix();
      o.geometry.translation() = e.point;
      break;
    }
    case ShapeType::Sphere:
      FEM_CLOTH_CHECK(positiveFinite(e.radius, key + ".radius", "m"));
      o.shape.radius = e.radius;
      break;
    case ShapeType::Box:
      for (int k = 0; k < 3; ++k) {
        FEM_CLOTH_CHECK(positiveFinite(e.size[k], key + ".size[" + std::to_string(k) + "]", "m"));
      }
      o.shape.halfExtents = 0.5 * e.size;
      break;
    case ShapeType::Capsule:
      FEM_CLOTH_CHECK(positiveFinite(e.radius, key + ".radius", "m"));
      FEM_CLOTH_CHECK(nonNegativeFinite(e.length, key + ".length", "m"));
      o.shape.radius = e.radius;
      o.shape.halfLength = 0.5 * e.length;
      break;
  }
  FEM_CLOTH_CHECK(nonNegativeFinite(e.friction, key + ".friction", "dimensionless"));
  o.friction = e.friction;
  o.frame = e.frame;
  FEM_CLOTH_CHECK(finiteVector(e.velocity, key + ".velocity"));
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
    if (!(*s.youngsModulus > 0.0) || !std::isfinite(*s.youngsModulus)) {
      return Error{"material.youngs_modulus must be positive and finite (Pa), got " +
                   numberText(*s.youngsModulus)};
    }
    if (!(*s.poissonRatio >= 0.0 && *s.poissonRatio < 0.5)) {
      return Error{"material.poisson_ratio must be in [0, 0.5), got " + numberText(*s.poissonRatio)};
    }
    volumetric = Lame::fromYoungPoisson(*s.youngsModulus, *s.poissonRatio);
  } else {
    if (!s.mu || !s.lambda) return Error{"material: mu and lambda must be given together"};
    if (!(*s.mu > 0.0) || !std::isfinite(*s.mu)) {
      return Error{"material.mu must be positive and finite (Pa), got " + numberText(*s.mu)};
    }
    if (!(*s.lambda >= 0.0) || !std::isfinite(*s.lambda)) {
      return Error{"material.lambda must be zero or positive and finite (Pa), got " +
                   numberText(*s.lambda)};
    }
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
  if (gridForms && scene.meshType != "grid") {
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

namespace {

Expected<Mesh> buildMesh(const Scene& s) {
  if (s.meshType == "grid") return makeGrid(s.grid);
  if (s.meshType == "obj") {
    std::string path = s.objFile;
    if (!path.empty() && path[0] != '/' && !s.sourcePath.empty()) {
      const auto slash = s.sourcePath.find_last_of('/');
      if (slash != std::string::npos) path = s.sourcePath.substr(0, slash + 1) + path;
    }
    return loadObj(path, s.dim);
  }
  Mesh mesh = s.explicitMesh;
  mesh.dim = s.dim;
  return mesh;
}

std::unique_ptr<Integrator> makeIntegrator(const Scene& s) {
  if (s.integrator == "symplectic_euler") {
    SymplecticEulerSettings settings;
    settings.autoSubstep = s.autoSubstep;
    settings.cflSafety = s.cflSafety;
    return std::make_unique<SymplecticEuler>(settings);
  }
  if (s.integrator == "projective_dynamics") {
    ProjectiveDynamicsSettings settings;
    settings.iterations = s.iterations;
    settings.chebyshevRho = s.chebyshevRho;
    return std::make_unique<ProjectiveDynamics>(settings);
  }
  if (s.integrator == "xpbd") {
    XpbdSettings settings;
    settings.iterations = s.iterations;
    return std::make_unique<Xpbd>(settings);
  }
  return std::make_unique<ImplicitIntegrator>(
      s.integrator == "bdf2" ? ImplicitScheme::Bdf2 : ImplicitScheme::BackwardEuler, s.newton);
}

}  // namespace

Expected<Simulation> buildSimulation(const Scene& scene) {
  if (Status s = validateScene(scene); !s) return Error{s.error()};
  Expected<Mesh> built = buildMesh(scene);
  if (!built) return Error{"mesh: " + built.error()};
  const MeshValidation check = validateMesh(*built, scene.minTriangleQuality);
  if (!check.ok()) return Error{"mesh: " + check.errorSummary()};
  auto mesh = std::make_shared<const Mesh>(std::move(built).value());
  Expected<RestState> restState = computeRestState(*mesh);
  if (!restState) return Error{"mesh: " + restState.error()};
  auto rest = std::make_shared<const RestState>(std::move(restState).value());
  const Lame lame = *membraneLame(scene);
  Expected<Material> material = makeMaterial(scene.materialModel, lame);
  if (!material) return Error{"material.model: " + material.error()};

  Simulation sim;
  sim.mesh = mesh;
  sim.warnings = check.warnings;
  sim.model = std::make_shared<Model>(mesh, rest,
                                       lumpedMasses(*mesh, *rest, scene.density * scene.thickness));
  sim.model->addTerm(makeMembraneTerm(mesh, rest, *material), TermKind::Membrane);
  // Zero stiffness declares no bending term at all, so planar meshes (which cannot bend) build;
  // a planar mesh with a non-zero stiffness is an error naming the key.
  if (scene.bendingStiffness > 0.0) {
    BendingSpec spec;
    spec.model = scene.bendingModel;
    spec.stiffness = scene.bendingStiffness;
    spec.poissonRatio = scene.bendingPoissonRatio;
    if (spec.model == "midedge") {
      Expected<std::vector<char>> held = heldVertices(scene, mesh->numVertices());
      if (!held) return Error{held.error()};
      spec.held = std::move(held).value();
    }
    Expected<std::unique_ptr<EnergyTerm>> bending = makeBendingTerm(*mesh, *rest, spec);
    if (!bending) return Error{"bending.stiffness: " + bending.error()};
    sim.model->addTerm(std::move(bending).value(), TermKind::Bending);
  }

  SimulatorSettings settings;
  settings.gravity = scene.gravity;
  settings.damping = scene.damping;
  settings.dt = scene.dt;
  settings.minSubsteps = scene.substeps;
  settings.maxRetries = scene.maxRetries;
  sim.simulator = std::make_unique<Simulator>(sim.model, makeIntegrator(scene), settings);
  Simulator& simulator = *sim.simulator;
  const int d = mesh->dim;
  const Index n = mesh->numVertices();

  // Initial state.
  VectorX x = mesh->restPositions;
  for (const auto& p : scene.initialPositions) {
    if (p.vertex < 0 || p.vertex >= n) {
      return Error{"initial.positions: vertex " + std::to_string(p.vertex) +
                   " does not exist (the mesh has " + std::to_string(n) + " vertices)"};
    }
    x.segment(d * p.vertex, d) = p.position.head(d);
  }
  VectorX v = VectorX::Zero(x.size());
  for (Index i = 0; i < n; ++i) v.segment(d * i, d) = scene.initialVelocity.head(d);

  // Pins (targets from the initial positions) and forces that act from the start.
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
      // A trajectory is followed as a velocity that changes at its waypoints: exact when the
      // waypoint times fall on step boundaries.
      Eigen::Vector3d velocity = p.velocity;
      if (!p.trajectory.empty()) {
        const std::vector<TrajectoryPoint>& w = p.trajectory;
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
          sim.script.add(e);
        }
      }
      x.segment(d * vert, d) = target.head(d);
      v.segment(d * vert, d) = velocity.head(d);
      if (Status st = simulator.pin(vert, target, velocity); !st) return Error{key + ": " + st.error()};
      if (std::isfinite(p.releaseAt)) {
        SceneScript::Event e;
        e.time = p.releaseAt;
        e.kind = SceneScript::Event::Kind::ReleasePin;
        e.vertex = vert;
        sim.script.add(e);
      }
    }
  }
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
        sim.script.add(e);
      }
    }
  }
  if (Status st = simulator.setInitialState(x, v); !st) return Error{"initial: " + st.error()};
  if (sceneHasContact(scene)) {
    std::vector<Obstacle> obstacles;
    for (std::size_t i = 0; i < scene.obstacles.size(); ++i) {
      obstacles.push_back(*makeObstacle(scene.obstacles[i], "obstacles[" + std::to_string(i) + "]"));
    }
    auto contact = std::make_unique<ContactModel>(*sim.model, std::move(obstacles), scene.contact,
                                                  scene.gravity.norm());
    // Every free vertex starts outside the obstacles (those that follow a tf frame are placed
    // only when the node runs).
    std::vector<char> pinnedDofs(x.size(), 0);
    for (Index vert : simulator.pinnedVertices()) {
      for (int k = 0; k < d; ++k) pinnedDofs[d * vert + k] = 1;
    }
    for (std::size_t k = 0; k < scene.obstacles.size(); ++k) {
      if (!contact->obstacle(k).frame.empty()) continue;
      for (Index vert = 0; vert < n; ++vert) {
        if (pinnedDofs[d * vert]) continue;
        const double dist = signedDistance(contact->obstacle(k).shape,
                                           contact->shapePose(k).inverse() * Eigen::Vector3d(x.segment<3>(3 * vert)))
                                .distance;
        if (!(dist > 0.0)) {
          return Error{"obstacles[" + std::to_string(k) + "] ('" + contact->obstacle(k).name +
                       "'): vertex " + std::to_string(vert) + " starts inside it or on its surface (distance " +
                       numberText(dist) + " m); move the obstacle or the cloth"};
        }
      }
    }
    if (scene.contact.selfCollision) {
      // Parts of the cloth that share no vertex must be farther apart than dHat at rest, or the
      // barrier would push them apart from the start.
      const double rest = contact->minimumSelfDistance(mesh->restPositions);
      if (rest < scene.contact.distance) {
        return Error{"contact.distance (" + numberText(scene.contact.distance) +
                     " m) must be below the smallest rest distance between parts of the cloth that "
                     "share no vertex (" + numberText(rest) + " m) for self_collision; use a smaller distance "
                     "or a coarser mesh"};
      }
      const double now = contact->minimumSelfDistance(x);
      if (!(now > 0.0)) {
        return Error{"initial: the cloth starts intersecting itself (with self_collision on)"};
      }
    }
    simulator.setContact(std::move(contact));
  }
  const Model::Energies e0 = sim.model->energies(x);
  if (!std::isfinite(e0.total())) {
    return Error{"initial: the initial positions put an element outside the material's domain "
                 "(J <= 0 for " + scene.materialModel + ")"};
  }
  return sim;
}

}  // namespace fem_cloth
