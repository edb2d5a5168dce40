// The air model (core/air.h, docs/air.md) against closed forms written here: the force on an
// inclined plate by hand (drag and lift), its derivatives by finite differences (D's gradient is
// minus the force, its Hessian is PSD), a flat sheet falling to the terminal speed
// sqrt(2 rho_s g / (rho C_n)), a sheet sliding in its plane slowed as v0 / (1 + k v0 t), and wind
// accelerating a sheet at rest with the energy balance holding and the air's work positive; with
// every integrator. Scenes are read from YAML, so the scene keys are tested too.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <random>

#include "fem_cloth/core/air.h"
#include "fem_cloth/core/live_change.h"
#include "fem_cloth/io/live_change.h"
#include "fem_cloth/io/scene_yaml.h"

using namespace fem_cloth;

namespace {

constexpr double kG = 9.81;

// A 5 x 5 vertex sheet of 1 m x 1 m in the xy plane, areal density rho_s = 1 kg/m^2, soft ARAP
// (so every integrator runs it), no bending, no damping; `extra` adds keys (air, gravity...).
std::string sheet(const std::string& integrator, double dt, const std::string& extra) {
  return "name: air\n"
         "mesh: {type: grid, rows: 5, cols: 5, width: 1.0, height: 1.0}\n"
         "material: {model: arap, mu: 1.0e5, lambda: 1.0e5, thickness: 1.0e-3, density: 1000}\n"
         "integrator: {name: " + integrator + ", dt: " + std::to_string(dt) + "}\n" + extra;
}

Simulation build(const std::string& yaml) {
  Expected<Scene> scene = parseScene(YAML::Load(yaml));
  if (!scene) throw std::runtime_error(scene.error());
  Expected<Simulation> sim = buildSimulation(*scene);
  if (!sim) throw std::runtime_error(sim.error());
  return std::move(sim).value();
}

// Mean velocity of the sheet (all vertices move alike in these tests).
Eigen::Vector3d meanVelocity(const Simulator& s) {
  const VectorX& v = s.state().v;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (Index i = 0; i < v.size() / 3; ++i) sum += v.segment<3>(3 * i);
  return sum / static_cast<double>(v.size() / 3);
}

std::string runSteps(Simulator& s, int steps) {
  for (int k = 0; k < steps; ++k) {
    const StepReport r = s.step();
    if (!r.ok) return r.error;
  }
  return "";
}

const std::vector<std::string> kIntegrators = {"symplectic_euler", "backward_euler", "bdf2", "xpbd",
                                               "projective_dynamics"};

}  // namespace

// One triangle at 45 degrees (normal (1, 0, 1)/sqrt 2) at rest in a wind W along x. By hand:
// v_r = -W x, v_r . n = -W/sqrt 2, v_n = -W/2 (1, 0, 1), v_t = -W/2 (1, 0, -1), |v_n| = |v_t| =
// W/sqrt 2, so f = 1/2 rho A W^2 / (2 sqrt 2) [C_n (1, 0, 1) + C_t (1, 0, -1)]: a drag along the
// wind and a lift across it, 1/2 rho A W^2 (C_n - C_t) / (2 sqrt 2) upward.
TEST(Air, InclinedPlateFeelsDragAndLiftByHand) {
  auto mesh = std::make_shared<Mesh>();
  mesh->dim = 3;
  mesh->restPositions.resize(9);
  mesh->restPositions << 0, 0, 0, 0, 1, 0, -1, 0, 1;  // normal along (1, 0, 1) up to sign
  mesh->triangles = {{0, 1, 2}};
  AirSettings settings;
  settings.density = 1.2;
  settings.normalDrag = 1.1;
  settings.tangentialDrag = 0.05;
  settings.wind = Eigen::Vector3d(3.0, 0.0, 0.0);
  const double area = 0.5 * std::sqrt(2.0);
  const double scale = 0.5 * 1.2 * area * 9.0 / (2.0 * std::sqrt(2.0));
  const Eigen::Vector3d expected(scale * (1.1 + 0.05), 0.0, scale * (1.1 - 0.05));
  for (bool flipped : {false, true}) {
    if (flipped) mesh->triangles = {{0, 2, 1}};  // two-sided: the normal's sign does not matter
    AirModel air(mesh, settings);
    air.lag(mesh->restPositions);
    VectorX f;
    air.force(VectorX::Zero(9), f);
    Eigen::Vector3d total = f.segment<3>(0) + f.segment<3>(3) + f.segment<3>(6);
    EXPECT_NEAR((total - expected).norm(), 0.0, 1e-12 * expected.norm()) << total.transpose();
    EXPECT_NEAR((f.segment<3>(0) - expected / 3.0).norm(), 0.0, 1e-12);  // shared equally
  }
}

// D's velocity gradient is minus the force and its Hessian the gradient's derivative (central
// differences), and the Hessian is PSD (D convex), on a crumpled sheet moving in a wind.
TEST(Air, DissipationPotentialDerivativesByFiniteDifferences) {
  Simulation sim = build(sheet("backward_euler", 0.01,
                               "air: {normal_drag: 1.2, tangential_drag: 0.3, wind: [1, -2, 0.5]}\n"));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  VectorX x = sim.mesh->restPositions;
  for (Index i = 0; i < x.size(); ++i) x[i] += 0.05 * u(rng);
  VectorX v(x.size());
  for (Index i = 0; i < v.size(); ++i) v[i] = 2.0 * u(rng);
  AirModel air(sim.mesh, sim.simulator->air()->settings());
  air.lag(x);
  VectorX f, fPlus, fMinus;
  air.force(v, f);
  const double eps = 1e-6;
  for (Index i = 0; i < v.size(); ++i) {
    VectorX vp = v, vm = v;
    vp[i] += eps;
    vm[i] -= eps;
    const double dD = (air.dissipation(vp) - air.dissipation(vm)) / (2 * eps);
    EXPECT_NEAR(dD, -f[i], 1e-6 * (1.0 + std::abs(f[i]))) << "dof " << i;
  }
  SparseHessian& H = sim.model->hessianPattern();
  H.setZero();
  air.addHessian(v, 1.0, H);
  const Eigen::MatrixXd dense = Eigen::MatrixXd(H.matrix());
  double worst = 0.0;
  for (Index j = 0; j < v.size(); ++j) {
    VectorX vp = v, vm = v;
    vp[j] += eps;
    vm[j] -= eps;
    air.force(vp, fPlus);
    air.force(vm, fMinus);
    const VectorX column = -(fPlus - fMinus) / (2 * eps);
    worst = std::max(worst, (column - dense.col(j)).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 1e-6 * dense.cwiseAbs().maxCoeff());
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(dense);
  EXPECT_GE(eig.eigenvalues().minCoeff(), -1e-12 * eig.eigenvalues().maxCoeff());
  EXPECT_GT(air.dissipation(v), 0.0);
}

// A flat horizontal sheet falling under gravity: m dv/dt = -m g + 1/2 rho A C_n v^2, so
// v(t) = v_t tanh(g t / v_t), v_t = sqrt(2 rho_s g / (rho C_n)) = 4.04 m/s for rho_s = 1 kg/m^2,
// rho = 1.2, C_n = 1 (time constant v_t / g = 0.41 s). After 3 s (7 time constants) every
// integrator falls at v_t within 1 %, and the air's work is what the fall lost: negative.
TEST(Air, FlatSheetFallsAtTheTerminalSpeed) {
  const double vt = std::sqrt(2.0 * 1.0 * kG / (1.2 * 1.0));
  for (const std::string& integrator : kIntegrators) {
    SCOPED_TRACE(integrator);
    Simulation sim = build(sheet(integrator, 0.01, "air: {density: 1.2, normal_drag: 1.0}\n"));
    Simulator& s = *sim.simulator;
    ASSERT_EQ(runSteps(s, 300), "");
    const Eigen::Vector3d v = meanVelocity(s);
    EXPECT_NEAR(-v.z(), vt, 0.01 * vt);
    EXPECT_NEAR(v.head<2>().norm(), 0.0, 1e-9);
    const EnergyReport e = s.energies();
    EXPECT_LT(e.airWork, 0.0);
    // Gravity's work = kinetic energy - air work (the sheet does not deform), to the balance.
    EXPECT_LT(std::abs(e.balanceError), 0.02 * std::abs(e.airWork));
  }
}

// A sheet sliding in its own plane at v0, no gravity, only tangential drag:
// dv/dt = -k v^2, k = rho C_t / (2 rho_s), so v(t) = v0 / (1 + k v0 t). rho = 1.2, C_t = 0.5,
// rho_s = 1: k = 0.3 1/m; v0 = 10 m/s: v(1 s) = 2.5 m/s.
TEST(Air, SheetSlidingInItsPlaneSlowsAsTheClosedForm) {
  const double k = 1.2 * 0.5 / 2.0, v0 = 10.0, t = 1.0;
  const double expected = v0 / (1.0 + k * v0 * t);
  for (const std::string& integrator : kIntegrators) {
    SCOPED_TRACE(integrator);
    Simulation sim = build(sheet(integrator, 0.002,
                                 "air: {density: 1.2, normal_drag: 1.0, tangential_drag: 0.5}\n"
                                 "gravity: [0, 0, 0]\ninitial: {velocity: [10, 0, 0]}\n"));
    Simulator& s = *sim.simulator;
    ASSERT_EQ(runSteps(s, 500), "");
    const Eigen::Vector3d v = meanVelocity(s);
    EXPECT_NEAR(v.x(), expected, 0.01 * expected);
    EXPECT_NEAR(v.z(), 0.0, 1e-9);
  }
}

// Wind W = 5 m/s along the normal of a sheet at rest, all vertices free, no gravity: the relative
// speed u = W - v obeys du/dt = -K u^2, K = rho C_n / (2 rho_s) = 0.6 1/m, so
// v(t) = W - W / (1 + K W t): 4.286 m/s at 2 s. The air does positive work, and it is what the
// sheet's kinetic energy gained (up to the numerical dissipation the balance reports).
TEST(Air, WindAcceleratesASheetAtRestAndTheBalanceHolds) {
  const double W = 5.0, K = 0.6, t = 2.0;
  const double expected = W - W / (1.0 + K * W * t);
  for (const std::string& integrator : kIntegrators) {
    SCOPED_TRACE(integrator);
    Simulation sim = build(sheet(integrator, 0.005, "air: {wind: [0, 0, 5]}\ngravity: [0, 0, 0]\n"));
    Simulator& s = *sim.simulator;
    ASSERT_EQ(runSteps(s, 400), "");
    EXPECT_NEAR(meanVelocity(s).z(), expected, 0.01 * expected);
    const EnergyReport e = s.energies();
    EXPECT_GT(e.airWork, 0.0);
    EXPECT_NEAR(e.kinetic, 0.5 * expected * expected, 0.02 * 0.5 * expected * expected);
    // The implicit schemes book the air's work as f(v+) . dx, exact for backward Euler's
    // discrete energy identity; for BDF2 that right-end rule is first order, h / (2 tau) = 0.75 %
    // of the work here (tau = 1 / (K W) = 0.33 s), which shows as energy "created".
    EXPECT_LT(std::abs(e.balanceError), 0.01 * e.airWork);
    EXPECT_LT(e.created, 0.01 * e.airWork);
  }
}

// The wind changes live (air.wind=...), and the run goes on from where it was with the new wind.
TEST(Air, WindChangesLive) {
  const std::string yaml = sheet("backward_euler", 0.01, "air: {wind: [0, 0, 0]}\ngravity: [0, 0, 0]\n");
  const YAML::Node doc = YAML::Load(yaml);
  Simulation sim = build(yaml);
  ASSERT_EQ(runSteps(*sim.simulator, 5), "");
  EXPECT_EQ(meanVelocity(*sim.simulator).norm(), 0.0);  // no wind, no gravity: at rest
  Expected<LiveChange> change = applyLiveChange(doc, {"air.wind=[0, 0, 3]"});
  ASSERT_TRUE(change.ok()) << change.error();
  Expected<Simulation> next = changeLive(sim, change->scene);
  ASSERT_TRUE(next.ok()) << next.error();
  ASSERT_EQ(runSteps(*next->simulator, 10), "");
  EXPECT_GT(meanVelocity(*next->simulator).z(), 0.1);
  EXPECT_GT(next->simulator->energies().airWork, 0.0);
}

// Bad values are refused naming the key; absent air builds no air model.
TEST(Air, SceneKeysAreValidated) {
  auto error = [](const std::string& extra) {
    Expected<Scene> scene = parseScene(YAML::Load(sheet("backward_euler", 0.01, extra)));
    return scene ? std::string() : scene.error();
  };
  EXPECT_NE(error("air: {density: -1}\n").find("air.density"), std::string::npos);
  EXPECT_NE(error("air: {normal_drag: .nan}\n").find("air.normal_drag"), std::string::npos);
  EXPECT_NE(error("air: {tangential_drag: 50}\n").find("air.tangential_drag"), std::string::npos);
  EXPECT_NE(error("air: {wind: [1e9, 0, 0]}\n").find("air.wind"), std::string::npos);
  EXPECT_NE(error("air: {speed: 3}\n").find("speed"), std::string::npos);
  EXPECT_EQ(error("air: {}\n"), "");
  Simulation without = build(sheet("backward_euler", 0.01, ""));
  EXPECT_EQ(without.simulator->air(), nullptr);
  Simulation with = build(sheet("backward_euler", 0.01, "air: {}\n"));
  ASSERT_NE(with.simulator->air(), nullptr);
  EXPECT_EQ(with.simulator->air()->settings().density, 1.2);
}

// A live air key on a scene without `air` turns the air on (with the defaults for the rest).
TEST(Air, ALiveAirKeyTurnsTheAirOn) {
  const std::string yaml = sheet("backward_euler", 0.01, "gravity: [0, 0, 0]\n");
  Simulation sim = build(yaml);
  ASSERT_EQ(sim.simulator->air(), nullptr);
  Expected<LiveChange> change = applyLiveChange(YAML::Load(yaml), {"air.wind=[0, 0, 3]"});
  ASSERT_TRUE(change.ok()) << change.error();
  Expected<Simulation> next = changeLive(sim, change->scene);
  ASSERT_TRUE(next.ok()) << next.error();
  ASSERT_NE(next->simulator->air(), nullptr);
  EXPECT_EQ(next->simulator->air()->settings().wind, Eigen::Vector3d(0, 0, 3));
  EXPECT_EQ(next->simulator->air()->settings().normalDrag, 1.0);
}
