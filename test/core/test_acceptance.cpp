// A step is accepted only when it is right (issue 11): the runs that used to report success for
// a physically wrong state, each checked against physics written here, independently of the
// integrators:
//  - a huge step must leave the forces balanced (residual of the backward Euler equations,
//    computed here from positions, masses and the model's FD-checked gradient) or be refused;
//  - a strip under a sudden end load must end where the uniaxial closed form of its material
//    puts it, without creating energy and without folding, with every integrator;
//  - projective dynamics must pull a strip longer, not leave it hanging shorter than at rest;
//  - the linear membrane must not be used outside its small-deformation range.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <iostream>
#include <limits>
#include <tuple>

#include "config_scene.h"
#include "fem_cloth/validate/uniaxial.h"
#include "test_support.h"

using namespace fem_cloth;
using namespace fem_cloth::test;

namespace {

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

/// The largest unbalanced force of the backward Euler equations on a free DOF after a step of h
/// from (x0, v0) to x (with v = (x - x0) / h), relative to that DOF's weight m_i |g|:
///   r = M (x - x0 - h v0) / h^2 + dE/dx(x) - M g + alpha M (x - x0) / h.
double relativeBackwardEulerResidual(Simulator& s, const VectorX& x0, const VectorX& v0, double h) {
  const VectorX& x = s.state().x;
  VectorX gradient = VectorX::Zero(x.size());
  EvalRequest request;
  request.energy = false;
  request.gradient = &gradient;
  s.model().evaluate(x, request);
  const VectorX& m = s.model().dofMasses();
  const int d = s.dim();
  const double alpha = s.settings().damping.massProportional;
  double worst = 0.0;
  for (Index i = 0; i < x.size(); ++i) {
    if (s.isPinned(i / d)) continue;
    const double r = m[i] * (x[i] - x0[i] - h * v0[i]) / (h * h) + gradient[i] -
                     m[i] * s.settings().gravity[i % d] + alpha * m[i] * (x[i] - x0[i]) / h;
    worst = std::max(worst, std::abs(r) / (m[i] * kG));
  }
  return worst;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// A huge step: balanced, or refused
// ---------------------------------------------------------------------------------------------

// The hanging cloth (9 x 9 here) taking one backward Euler step of 100 s or 10 s from rest used
// to be accepted with unbalanced forces of 4912 N and 8.3 N on a cloth whose vertices weigh
// 0.12 N (a "converged" test that shrank to nothing relative to h), 104 % stretch at 100 s.
// Such a step is a quasi-static solve: the pins carry the weight and every free vertex is in
// equilibrium. Either the simulator takes it, and then the forces balance to 1 % of each
// vertex's weight, the pins carry the cloth's 9.81 N and no edge stretches beyond a few per
// cent (1e4 N/m against 10 N); or it refuses it, naming the unbalanced force, and keeps its state.
class HugeStep : public ::testing::TestWithParam<double> {};

TEST_P(HugeStep, IsBalancedOrRefused) {
  const double dt = GetParam();
  Scene scene = configScene("hanging_cloth.yaml");
  scene.grid.rows = scene.grid.cols = 9;
  scene.integrator = "backward_euler";
  scene.dt = dt;
  Simulation sim = mustBuild(scene);
  Simulator& s = *sim.simulator;
  const VectorX x0 = s.state().x, v0 = s.state().v;
  const StepReport r = s.step();
  if (!r.ok) {
    std::cout << "dt " << dt << " s refused: " << r.error << '\n';
    EXPECT_TRUE(contains(r.error, "unbalanced force")) << r.error;
    EXPECT_EQ(s.state().x, x0);
    EXPECT_EQ(s.time(), 0.0);
    return;
  }
  const double h = r.dtUsed;
  ASSERT_EQ(r.substeps, static_cast<int>(std::lround(dt / h)));
  // With substeps the last one starts where the one before ended: re-run the step's substeps
  // for the check only when there is one.
  const double residual = r.substeps == 1 ? relativeBackwardEulerResidual(s, x0, v0, h) : 0.0;
  double pinsCarry = 0.0;
  for (Index v : s.pinnedVertices()) pinsCarry -= s.pinReactions()[3 * v + 2];
  const double stretch = maxEdgeStretch(*sim.mesh, s.state().x);
  std::cout << "dt " << dt << " s taken in " << r.substeps << " substeps: largest unbalanced force "
            << residual << " x a vertex's weight, pins carry " << pinsCarry << " N, stretch "
            << stretch << '\n';
  EXPECT_LT(residual, 0.01);
  EXPECT_NEAR(pinsCarry, s.model().totalMass() * kG, 0.01 * s.model().totalMass() * kG);
  EXPECT_LT(stretch, 0.05);
}

INSTANTIATE_TEST_SUITE_P(BackwardEuler, HugeStep, ::testing::Values(100.0, 10.0));

// ---------------------------------------------------------------------------------------------
// The sudden-load strip
// ---------------------------------------------------------------------------------------------

namespace {

// The strip of issue 11: 0.4 m x 0.1 m, 6 rows x 21 columns, 0.2 kg/m^2, E h = 1e4 N/m,
// nu = 0.3, first column pinned, 4 N per vertex along +x on the last column (2 N on its two
// corners: the consistent nodal loads of a uniform traction), mass damping 30/s, no gravity,
// dt 0.01 s. Total end force 20 N over 0.1 m: a nominal tension T = 200 N/m.
constexpr int kStripRows = 6, kStripCols = 21;
constexpr double kStripLength = 0.4, kStripWidth = 0.1, kStripForce = 20.0;
constexpr double kYoungThickness = 1e4, kPoisson = 0.3;  // N/m, 1

Scene stripScene(const std::string& material, const std::string& integrator) {
  Scene s;
  s.name = "strip";
  s.grid.rows = kStripRows;
  s.grid.cols = kStripCols;
  s.grid.width = kStripLength;
  s.grid.height = kStripWidth;
  s.materialModel = material;
  s.thickness = 5e-4;
  s.youngsModulus = kYoungThickness / s.thickness;
  s.poissonRatio = kPoisson;
  s.density = 0.2 / s.thickness;
  s.damping.massProportional = 30.0;
  s.gravity = Eigen::Vector3d::Zero();
  s.integrator = integrator;
  s.dt = 0.01;
  ScenePin pin;
  pin.select.gridEdge = "first_col";
  s.pins.push_back(pin);
  const double perVertex = kStripForce / (kStripRows - 1);
  SceneForce inner, corners;
  for (int r = 1; r + 1 < kStripRows; ++r) inner.select.gridVertices.push_back({r, -1});
  inner.force = {perVertex, 0.0, 0.0};
  corners.select.gridVertices = {{0, -1}, {-1, -1}};
  corners.force = {0.5 * perVertex, 0.0, 0.0};
  s.forces = {inner, corners};
  // A position-based method needs small steps for a load this large on vertices this light
  // (4 N on 4e-5 kg): its Gauss-Seidel sweeps converge fast only where h^2 k / m is small,
  // h about the CFL bound (2 / omega_max = 9e-5 s here), as symplectic Euler's.
  if (integrator == "xpbd") {
    s.substeps = 256;
    s.iterations = 2;
  }
  return s;
}

// The material's closed form for uniaxial tension under plane stress (validate/uniaxial.h: the
// energy densities of docs/materials.md written out independently of the model code), with the
// plane-stress membrane moduli mu = E h / (2 (1 + nu)), lambda = E h nu / (1 - nu^2).
struct Uniaxial {
  double axial = 1.0, transverse = 1.0;  // principal stretches s1, s2
};

Uniaxial uniaxialStretch(const std::string& model, double tension) {
  const double mu = kYoungThickness / (2.0 * (1.0 + kPoisson));
  const double lambda = kYoungThickness * kPoisson / (1.0 - kPoisson * kPoisson);
  const validate::UniaxialState u = validate::uniaxialAtStress(model, mu, lambda, tension);
  return {u.stretch, u.transverse};
}

Eigen::Vector3d positionOf(const Simulator& s, int row, int col) {
  return Eigen::Vector3d(s.state().x.segment<3>(3 * (row * kStripCols + col)));
}

// The axial stretch s1 measured in the middle of the strip, between columns 7 and 13 (a strip
// width and more from the pinned end, whose clamp keeps the width from contracting), averaged
// over the rows; the transverse stretch s2 over the same columns.
Uniaxial measuredStretch(const Simulator& s) {
  const int c1 = 7, c2 = 13;
  const double spacing = kStripLength / (kStripCols - 1);
  Uniaxial u;
  u.axial = 0.0;
  for (int r = 0; r < kStripRows; ++r) {
    u.axial += (positionOf(s, r, c2).x() - positionOf(s, r, c1).x()) / ((c2 - c1) * spacing);
  }
  u.axial /= kStripRows;
  u.transverse = 0.0;
  for (int c = c1; c <= c2; ++c) {
    u.transverse += (positionOf(s, kStripRows - 1, c).y() - positionOf(s, 0, c).y()) / kStripWidth;
  }
  u.transverse /= (c2 - c1 + 1);
  return u;
}

// The smallest z component of the unit normals of the triangles (all +1 while the strip lies
// flat as it started; a triangle that folds over has -1).
double lowestNormal(const Mesh& mesh, const VectorX& x) {
  double lowest = 1.0;
  for (const Triangle& t : mesh.triangles) {
    const Eigen::Vector3d a = x.segment<3>(3 * t[0]), b = x.segment<3>(3 * t[1]), c = x.segment<3>(3 * t[2]);
    const Eigen::Vector3d rest = (mesh.restPositions.segment<3>(3 * t[1]) - mesh.restPositions.segment<3>(3 * t[0]))
                                     .cross(mesh.restPositions.segment<3>(3 * t[2]) - mesh.restPositions.segment<3>(3 * t[0]));
    const Eigen::Vector3d now = (b - a).cross(c - a);
    lowest = std::min(lowest, now.normalized().dot(rest.normalized()));
  }
  return lowest;
}

}  // namespace

// The strip is loaded suddenly (4 N on vertices of 4e-5 kg) and left for 0.5 s: with mass
// damping of 30/s every mode decays at least like exp(-15 t), to 6e-4 of its amplitude (with or
// without numerical damping), so the end state is the static one. There:
//  - the middle of the strip is in uniaxial tension T = 200 N/m: its stretches are the material's
//    closed form (above), to 2 % of the strain; the loaded end is beyond the rest length;
//  - the strip still lies flat (no triangle folded over, nothing moved out of its plane);
//  - no energy was created: kinetic + strain - work of the end forces + energy the damping
//    removed is at most 1 % of the work put in (the work is 20 N x the end displacement; an
//    implicit method may lose energy to numerical dissipation, never gain it).
// Before issue 11, backward Euler and BDF2 folded the loaded end over itself in the first step
// (from an initial guess 10 m away), then cycled with 66 Newton iterations a step, creating
// energy, "0 failures"; XPBD refused the scene at t = 0.
class SuddenLoadStrip : public ::testing::TestWithParam<std::tuple<std::string, std::string>> {};

TEST_P(SuddenLoadStrip, EndsAtTheUniaxialClosedForm) {
  const auto& [material, integrator] = GetParam();
  const Uniaxial expected = uniaxialStretch(material, kStripForce / kStripWidth);
  Simulation sim = mustBuild(stripScene(material, integrator));
  Simulator& s = *sim.simulator;
  double lowest = 1.0, flat = 0.0;
  const std::string error = run(sim, 50, [&](int, const StepReport&) {
    lowest = std::min(lowest, lowestNormal(*sim.mesh, s.state().x));
    for (Index i = 0; i < s.model().numVertices(); ++i) flat = std::max(flat, std::abs(s.state().x[3 * i + 2]));
  });
  ASSERT_EQ(error, "") << material << " / " << integrator;
  const Uniaxial measured = measuredStretch(s);
  const EnergyReport e = s.energies();
  double endX = 0.0;
  for (int r = 0; r < kStripRows; ++r) endX += positionOf(s, r, kStripCols - 1).x() / kStripRows;
  const double work = e.externalWork;
  const double created = e.kinetic + e.strain - work + e.dissipated;
  std::cout << material << " / " << integrator << ": stretch " << measured.axial << " x "
            << measured.transverse << " (closed form " << expected.axial << " x " << expected.transverse
            << "), end at " << endX << " m, work " << work << " J, strain " << e.strain
            << " J, energy created " << created << " J, lowest normal " << lowest << '\n';
  EXPECT_NEAR(measured.axial - 1.0, expected.axial - 1.0, 0.02 * (expected.axial - 1.0));
  EXPECT_NEAR(measured.transverse - 1.0, expected.transverse - 1.0,
              0.05 * std::abs(expected.transverse - 1.0) + 1e-4);
  EXPECT_GT(endX, kStripLength);
  EXPECT_GT(lowest, 0.99);
  EXPECT_LT(flat, 1e-9);
  EXPECT_GT(work, 0.0);
  EXPECT_LT(created, 0.01 * work);
  EXPECT_LT(e.kinetic, 1e-6 * work);
}

namespace {

// Every material with every integrator that takes it (projective dynamics: ARAP only).
std::vector<std::tuple<std::string, std::string>> stripCases() {
  std::vector<std::tuple<std::string, std::string>> cases;
  for (const std::string& material : materialNames()) {
    for (const std::string& integrator : allIntegrators()) {
      if (integrator == "projective_dynamics" && material != "arap") continue;
      cases.emplace_back(material, integrator);
    }
  }
  return cases;
}

}  // namespace

INSTANTIATE_TEST_SUITE_P(
    EveryMaterialAndIntegrator, SuddenLoadStrip, ::testing::ValuesIn(stripCases()),
    [](const auto& info) { return std::get<0>(info.param) + "_" + std::get<1>(info.param); });

// The 20 N strip with ARAP, projective dynamics at dt 0.1 s with 10 iterations and gravity (the
// case of issue 11: it settled 24-42 mm below its pins, shorter than at rest, with a balance
// error of +250 %, "0 failures"). Pulled by 20 N and carrying its own weight W = 0.078 N, the
// strip is a taut string: with no vertical force at its loaded end, the slope there is zero and
// grows linearly to W / T at the pins, so the loaded end hangs q L^2 / (2 T) = W L / (2 T)
// = 0.78 mm below the pinned one (q = W / L, T = 20 N; the membrane barely stretches, 2.6 %).
// In 4 s (40 steps, damping 30/s) it settles there: longer than at rest by ARAP's closed form
// and the sag within 30 % of the string's (the bending-free membrane is a string; the clamp
// and the stretch are the difference).
TEST(PulledStrip, ProjectiveDynamicsEndsLongerAndBalanced) {
  Scene scene = stripScene("arap", "projective_dynamics");
  scene.gravity = Eigen::Vector3d(0.0, 0.0, -kG);
  scene.dt = 0.1;
  scene.iterations = 10;
  Simulation sim = mustBuild(scene);
  Simulator& s = *sim.simulator;
  ASSERT_EQ(run(sim, 40), "");
  const Uniaxial expected = uniaxialStretch("arap", kStripForce / kStripWidth);
  const Uniaxial measured = measuredStretch(s);
  double endX = 0.0, endZ = 0.0;
  for (int r = 0; r < kStripRows; ++r) {
    endX += positionOf(s, r, kStripCols - 1).x() / kStripRows;
    endZ += positionOf(s, r, kStripCols - 1).z() / kStripRows;
  }
  const double weight = s.model().totalMass() * kG;
  const double sag = weight * kStripLength / (2.0 * kStripForce);
  const EnergyReport e = s.energies();
  std::cout << "projective dynamics: end at x " << endX << " m, z " << endZ << " m (string: " << -sag
            << " m), stretch " << measured.axial << " (closed form " << expected.axial
            << "), balance error " << e.balanceError << " J of work " << e.externalWork << " J\n";
  EXPECT_GT(endX, kStripLength);
  EXPECT_NEAR(measured.axial - 1.0, expected.axial - 1.0, 0.02 * (expected.axial - 1.0));
  EXPECT_NEAR(endZ, -sag, 0.3 * sag);
  EXPECT_LT(e.balanceError, 0.01 * e.externalWork);
}

// ---------------------------------------------------------------------------------------------
// The linear membrane inside its validity range
// ---------------------------------------------------------------------------------------------

namespace {

// |F - T| (spectral norm) of every triangle of a grid cloth in the xy plane, whose rest tangent
// frame is T = [e_x, e_y]: the displacement gradient, which measures rotation and stretch alike
// (a rotation by theta gives 2 sin(theta / 2), a stretch by e gives e).
double largestDisplacementGradient(const Mesh& mesh, const VectorX& x) {
  double worst = 0.0;
  for (const Triangle& t : mesh.triangles) {
    Eigen::Matrix<double, 3, 2> Ds;
    Eigen::Matrix2d Dm;
    for (int k = 0; k < 2; ++k) {
      Ds.col(k) = x.segment<3>(3 * t[k + 1]) - x.segment<3>(3 * t[0]);
      Dm.col(k) = (mesh.restPositions.segment<3>(3 * t[k + 1]) - mesh.restPositions.segment<3>(3 * t[0])).head<2>();
    }
    Eigen::Matrix<double, 3, 2> H = Ds * Dm.inverse();
    H(0, 0) -= 1.0;
    H(1, 1) -= 1.0;
    worst = std::max(worst, Eigen::JacobiSVD<Eigen::Matrix<double, 3, 2>>(H).singularValues()[0]);
  }
  return worst;
}

}  // namespace

// The linear membrane measures strain as sym(T^T F) - I, which is right only for small
// rotations and stretches: out of its plane it has no stiffness at all. `--set
// material.model=linear` on the hanging cloth used to fall 4.8 m, stretching 15230 % with zero
// strain energy, "0 failures". The stated range is |F - T| <= 0.1 (a rotation up to 0.1 rad or a
// stretch up to 10 %): every accepted state keeps every triangle inside it, and the step that
// would leave it is refused with a message naming the test, the element and the amount.
TEST(LinearValidity, HangingClothIsRefusedOutsideTheSmallDeformationRange) {
  Scene scene = configScene("hanging_cloth.yaml");
  scene.grid.rows = scene.grid.cols = 9;
  scene.materialModel = "linear";
  scene.integrator = "backward_euler";
  Simulation sim = mustBuild(scene);
  Simulator& s = *sim.simulator;
  double worst = 0.0;
  const std::string error = run(sim, 200, [&](int, const StepReport&) {
    worst = std::max(worst, largestDisplacementGradient(*sim.mesh, s.state().x));
  });
  std::cout << "linear hanging cloth: largest |F - T| accepted " << worst << ", stopped at t = "
            << s.time() << " s: " << error << '\n';
  EXPECT_LE(worst, 0.1);
  EXPECT_TRUE(contains(error, "validity range")) << error;
  EXPECT_TRUE(contains(error, "element ")) << error;
  EXPECT_LT(s.time(), 2.0);
}

// ---------------------------------------------------------------------------------------------
// Test (b) by hand
// ---------------------------------------------------------------------------------------------

// Energy created = end - start - work + dissipated, against tolerance x max(size scale, held,
// |work|). A step whose energy is infinite is never accepted: with the energy held infinite the
// bound would be too (the small stability matrix accepted a symplectic Euler step to an infinite
// StVK energy that way, then reported the cell non-finite).
TEST(EnergyTest, BoundsTheEnergyCreatedAndNeverAcceptsANonFiniteEnergy) {
  const StepAcceptance acceptance;
  EnergyStep e;
  e.start = 1.0;
  e.externalWork = 0.5;
  e.dissipated = 0.1;
  e.end = 1.0 + 0.5 - 0.1 + 0.05;  // 0.05 J created
  e.held = e.end;
  // Scale max(1, 1.45, 0.5) = 1.45: 0.05 J is within 5 % of it (0.0725 J), not within 1 %.
  EXPECT_TRUE(acceptance.energyConserved(e, 0.05, 1.0).ok());
  const Status tight = acceptance.energyConserved(e, 0.01, 1.0);
  ASSERT_FALSE(tight.ok());
  EXPECT_NE(tight.error().find("energy created"), std::string::npos) << tight.error();
  e.end = e.held = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(acceptance.energyConserved(e, 0.5, 1.0).ok());
  e.end = e.held = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(acceptance.energyConserved(e, 0.5, 1.0).ok());
}

// Test (b) over the run: the net energy the accepted steps created (their created() summed, the
// balance error) plus this step's, against 5 % of the run's energy scale. A step that creates
// little is refused once the run has created nearly the bound (slow growth that every step's own
// bound let through: symplectic Euler on the small stability matrix's pull_corner and squash
// cells created 7-99 % of their scale that way), and a run that lost energy before has room.
TEST(EnergyTest, BoundsTheEnergyCreatedOverTheRun) {
  const StepAcceptance acceptance;
  EXPECT_DOUBLE_EQ(acceptance.settings().runEnergyTolerance, 0.05);
  EnergyStep e;
  e.start = 10.0;
  e.end = 10.01;  // 0.01 J created in this step
  e.held = e.end;
  const double runScale = 20.0;  // bound 0.05 x 20 = 1 J
  EXPECT_TRUE(acceptance.runEnergyConserved(0.0, e, runScale).ok());
  EXPECT_TRUE(acceptance.runEnergyConserved(0.98, e, runScale).ok());  // 0.99 J <= 1 J
  const Status over = acceptance.runEnergyConserved(0.995, e, runScale);  // 1.005 J > 1 J
  ASSERT_FALSE(over.ok());
  EXPECT_NE(over.error().find("energy created over the run"), std::string::npos) << over.error();
  EXPECT_NE(over.error().find("5 % of the run's energy scale 20 J"), std::string::npos) << over.error();
  EXPECT_TRUE(acceptance.runEnergyConserved(-3.0, e, runScale).ok());  // lost 3 J before
  e.end = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(acceptance.runEnergyConserved(0.0, e, runScale).ok());
  AcceptanceSettings off;
  off.energy = false;
  EXPECT_TRUE(StepAcceptance(off).runEnergyConserved(0.995, EnergyStep{10.0, 10.01, 10.01}, runScale).ok());
}
