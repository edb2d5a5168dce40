// Moving round obstacles against the whole cloth surface, not just its vertices (issue 30,
// findings 1 and 2): the repro scenes of test/data/contact/ and config/sphere_drape.yaml, each
// state checked by obstacle_check.h (every vertex, 20 points on every edge and a grid of points
// inside every triangle against the obstacle's shape written out from its definition, at the
// state's time).
//   - a 2 cm rod rising at 1 m/s under a cloth pinned on its four edges tents the cloth: no point
//     of the cloth inside the rod, and the vertex right above the rod's middle stays above it;
//   - a 0.1 m ball doing the same at 1 m/s;
//   - faster balls (10 and 100 m/s) either push the cloth with no point inside or fail the step;
//     never a state with the cloth through the ball;
//   - the explicit steppers report how far their triangles reach into the ball between vertices;
//   - the sphere drape: no point of an edge inside the ball in any frame;
//   - the surface samples' lattice (surface_samples.h): its radius against closed forms and its
//     definition, its points counted by hand, its promise (lattice points outside the grown shape
//     keep the whole triangle outside the shape) by dense sampling, and the exact triangle
//     distance that checks that promise after each substep.
//   - the lattice points' friction: a plate on a rod touching it only between its vertices sticks
//     and slides as Coulomb's law says for an incline.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <iostream>

#include "config_scene.h"
#include "fem_cloth/core/contact/contact_model.h"
#include "fem_cloth/core/contact/edge_distance.h"
#include "fem_cloth/core/contact/surface_samples.h"
#include "obstacle_check.h"
#include "test_support.h"

using namespace fem_cloth;
using namespace fem_cloth::test;

namespace {

Scene dataScene(const std::string& file) {
  Expected<Scene> scene = loadScene(std::string(FEM_CLOTH_TEST_DATA_DIR) + "/contact/" + file);
  if (!scene) throw std::runtime_error(scene.error());
  return *scene;
}

// The rod of rod.yaml: a capsule 0.6 m long between its cap centres, radius 2 cm, pitch 1.5708
// and yaw 0.3 rad, centre (0, 0, -0.1) m at t = 0, rising at 1 m/s.
RoundObstacle rodOfScene() {
  RoundObstacle rod;
  rod.center = {0.0, 0.0, -0.1};
  rod.velocity = {0.0, 0.0, 1.0};
  rod.axis = RoundObstacle::axisFromPitchYaw(1.5708, 0.3);
  rod.halfLength = 0.3;
  rod.radius = 0.02;
  return rod;
}

// The ball of ball.yaml: radius 0.1 m, centre (0.03, 0.02, -0.15) m at t = 0, rising at `speed`.
RoundObstacle ballOfScene(double speed) {
  RoundObstacle ball;
  ball.center = {0.03, 0.02, -0.15};
  ball.velocity = {0.0, 0.0, speed};
  ball.radius = 0.1;
  return ball;
}

// The grid vertex at the cloth's centre (row 6, column 6 of 13: x = y = 0).
constexpr Index kCentre = 6 * 13 + 6;

/// Runs `steps` steps, checking after each that no vertex or edge point is inside `o`; returns
/// the run's error ("" if every step passed) and the closest approach in `closest`.
std::string runOutside(Simulation& sim, const RoundObstacle& o, double dt, int steps, Closest& closest,
                       const std::function<void(int)>& also = {}) {
  const Simulator& s = *sim.simulator;
  const Closest start = closestApproach(s.model().mesh(), s.state().x, o, 0.0);
  EXPECT_GT(start.distance, 0.0) << "at the start, " << start.where;
  return run(sim, steps, [&](int n, const StepReport&) {
    const Closest c = closestApproach(s.model().mesh(), s.state().x, o, n * dt);
    if (c.distance < closest.distance) closest = c;
    ASSERT_GT(c.distance, 0.0) << "step " << n << ": " << c.where << " inside";
    if (also) also(n);
  });
}

}  // namespace

TEST(ContactEdges, RisingRodTentsTheClothWithBackwardEuler) {
  Scene scene = dataScene("rod.yaml");
  const RoundObstacle rod = rodOfScene();
  Simulation sim = mustBuild(scene);
  const Simulator& s = *sim.simulator;
  Closest closest;
  // 0.4 s: the rod's top rises from -0.08 m to 0.32 m, 0.32 m above the pinned edges.
  ASSERT_EQ(runOutside(sim, rod, scene.dt, 40, closest, [&](int n) {
              // Right above the rod's axis the centre vertex stays above the rod.
              const double z = vertexPosition(s, kCentre).z(), axisZ = rod.centerAt(n * scene.dt).z();
              ASSERT_GT(z, axisZ + rod.radius) << "step " << n;
            }),
            "");
  EXPECT_GT(vertexPosition(s, kCentre).z(), 0.3 + rod.radius);
  std::cout << "rod: closest approach " << closest.distance << " m (" << closest.where << ")\n";
}

// The explicit steppers project vertices only: the rod would rise between them. They refuse the
// scene before the run (contact/surface_reach.h): its triangles' points lie up to 1.5 x 58.93 =
// 88.39 mm from a vertex (8.33 cm cells at contact.surface_stretch 1.5), more than the rod's
// radius and d̂ (22 mm), so the rod can pass between the vertices; no tolerance below its radius
// accepts that. With its radius as the tolerance (any depth, the user's choice) the run goes on
// and reports how deep the rod went: at least what the independent sampling of obstacle_check.h
// finds in the step-end states, more than half the radius.
TEST(ContactEdges, RisingRodIsRefusedByTheExplicitSteppersUpFront) {
  for (const std::string integrator : {"symplectic_euler", "xpbd"}) {
    Scene scene = dataScene("rod.yaml");
    scene.integrator = integrator;
    for (double tolerance : {-1.0, 0.01, 0.0199}) {
      scene.contact.surfaceTolerance = tolerance;
      const Expected<Simulation> refused = buildSimulation(scene);
      ASSERT_FALSE(refused.ok()) << integrator << ", tolerance " << tolerance;
      EXPECT_NE(refused.error().find("capsule 'rod'"), std::string::npos) << refused.error();
      EXPECT_NE(refused.error().find("is wide enough for the obstacle to pass between its vertices"), std::string::npos)
          << refused.error();
    }
    scene.contact.surfaceTolerance = 0.02;
    const RoundObstacle rod = rodOfScene();
    Simulation sim = mustBuild(scene);
    const Simulator& s = *sim.simulator;
    double reported = 0.0, sampled = 0.0;
    const std::string error = run(sim, 30, [&](int n, const StepReport& r) {
      reported = std::max(reported, r.boxDepth);
      sampled = std::max(sampled, -closestApproach(s.model().mesh(), s.state().x, rod, n * scene.dt).distance);
    });
    EXPECT_EQ(error, "") << integrator;
    EXPECT_GT(sampled, 0.5 * rod.radius) << integrator;
    EXPECT_GE(reported, sampled - 1e-9) << integrator;
    EXPECT_LE(reported, rod.radius + 1e-12) << integrator;
    std::cout << integrator << " with the rod's radius as tolerance: reported " << 1e3 * reported << " mm, sampled "
              << 1e3 * sampled << " mm\n";
  }
}

TEST(ContactEdges, RisingBallPushesTheClothWithBackwardEuler) {
  Scene scene = dataScene("ball.yaml");
  const RoundObstacle ball = ballOfScene(1.0);
  Simulation sim = mustBuild(scene);
  const Simulator& s = *sim.simulator;
  Closest closest;
  ASSERT_EQ(runOutside(sim, ball, scene.dt, 40, closest), "");
  // The ball's top ends at -0.15 + 0.4 + 0.1 = 0.35 m; the cloth over it is higher.
  EXPECT_GT(vertexPosition(s, kCentre).z(), 0.35 - 0.1);
  std::cout << "ball at 1 m/s: closest approach " << closest.distance << " m (" << closest.where << ")\n";
}

// The explicit steppers keep the vertices out of the ball, not the triangles between them: the
// 13 x 13 cloth's 8.3 cm cells sag far into the 0.1 m ball rising under it at 1 m/s. That run
// used to end "ok"; now the deepest point is measured exactly after every substep and reported
// (StepReport::boxDepth, a warning in fem_cloth_sim's status). Checked against the independent
// sampling of obstacle_check.h at every step's end: the exact maximum over the substeps is at
// least what the sampling finds, and within 1 mm of it (the ball rises 1 cm in a step).
TEST(ContactEdges, ExplicitSteppersReportHowFarTheirTrianglesReachIntoABall) {
  for (const std::string integrator : {"symplectic_euler", "xpbd"}) {
    Scene scene = dataScene("ball.yaml");
    scene.integrator = integrator;
    // Refused without it: the bound before the run is 49.09 mm (test_core_contact_surface_check).
    scene.contact.surfaceTolerance = 0.0491;
    const RoundObstacle ball = ballOfScene(1.0);
    Simulation sim = mustBuild(scene);
    const Simulator& s = *sim.simulator;
    double reported = 0.0, sampled = 0.0;
    std::string where;
    const std::string error = run(sim, 40, [&](int n, const StepReport& r) {
      if (r.boxDepth > reported) {
        reported = r.boxDepth;
        where = r.boxDepthWhere;
      }
      sampled = std::max(sampled, -closestApproach(s.model().mesh(), s.state().x, ball, n * scene.dt).distance);
    });
    EXPECT_EQ(error, "") << integrator;
    EXPECT_GT(sampled, 0.03) << integrator;
    EXPECT_GE(reported, sampled - 1e-9) << integrator;
    EXPECT_LT(reported, sampled + 1e-3) << integrator;
    EXPECT_NE(where.find(" in sphere 'ball'"), std::string::npos) << integrator << ": " << where;
    std::cout << integrator << ": reported " << reported * 1e3 << " mm into the ball (" << where << "), sampled "
              << sampled * 1e3 << " mm\n";
  }
}

// (Both fail their first step: Newton does not converge, and the message names the ball and its
// speed.)
TEST(ContactEdges, FastBallsPushTheClothOrFailTheStep) {
  for (const double speed : {10.0, 100.0}) {
    Scene scene = dataScene("ball.yaml");
    scene.obstacles[0].velocity = {0.0, 0.0, speed};
    const RoundObstacle ball = ballOfScene(speed);
    Simulation sim = mustBuild(scene);
    Closest closest;
    const std::string error = runOutside(sim, ball, scene.dt, 10, closest);
    // A failed step names the ball and its speed (the message's number: %.3g of the speed).
    if (!error.empty()) {
      char moving[64], crossing[64];
      std::snprintf(moving, sizeof moving, "obstacle 'ball' moves at %.3g m/s", speed);
      std::snprintf(crossing, sizeof crossing, "obstacle 'ball' (moving at %.3g m/s)", speed);
      EXPECT_TRUE(error.find(moving) != std::string::npos || error.find(crossing) != std::string::npos) << error;
    }
    std::cout << speed << " m/s: " << (error.empty() ? "all steps passed" : error) << "; closest approach "
              << closest.distance << " m\n";
  }
}

TEST(ContactEdges, SphereDrapeKeepsEveryEdgeOutsideTheBall) {
  Scene scene = configScene("sphere_drape.yaml");
  RoundObstacle ball;
  ball.center = {0.0, 0.0, 0.25};
  ball.radius = 0.25;
  Simulation sim = mustBuild(scene);
  Closest closest;
  // 1 s: the cloth, dropped from 5 cm above the ball's top, lands on it at 0.1 s, lies over its
  // top and its skirt swings down.
  ASSERT_EQ(runOutside(sim, ball, scene.dt, 100, closest), "");
  std::cout << "sphere drape: closest approach " << closest.distance << " m (" << closest.where << ")\n";
}

// A ball placed through the cloth between its vertices (no vertex inside it: the nearest is
// sqrt(0.03^2 + 0.02^2) = 3.6 cm from its centre, its radius 3 cm) is refused when the scene is
// built, naming the ball and a triangle, as a vertex inside it is.
TEST(ContactEdges, ClothThroughABallBetweenVerticesIsRefusedAtTheStart) {
  Scene scene = dataScene("ball.yaml");
  scene.obstacles[0].center = {0.03, 0.02, 0.0};
  scene.obstacles[0].radius = 0.03;
  scene.obstacles[0].velocity = {0.0, 0.0, 0.0};
  const Expected<Simulation> built = buildSimulation(scene);
  ASSERT_FALSE(built.ok());
  EXPECT_NE(built.error().find("obstacles[0] ('ball'): triangle "), std::string::npos) << built.error();
  EXPECT_NE(built.error().find("at the start"), std::string::npos) << built.error();
  // 3 cm lower, the ball clears the cloth: built.
  scene.obstacles[0].center.z() = -0.035;
  EXPECT_TRUE(buildSimulation(scene).ok());
}

// What the surface reaches into a box is measured after each substep and reported, and a
// triangle overlapping a box fails the substep (test_contact_boxes.cpp: the barriers that keep
// it out). A 3 x 3 sheet folded
// over the box's edge (x = z = 0.1 m): its first row 2 cm outside the +x face at z = 0.05, its
// second 2 cm above the top at x = 0.05, its third at x = -0.05. Between the first two rows a
// point at the fraction t of the way has x = 0.12 - 0.07 t and z = 0.05 + 0.07 t, so its depth
// min(0.1 - x, 0.1 - z) is largest at t = 1/2: 0.015 m (by hand), on the measuring grid.
TEST(ContactEdges, BoxDepthOfASheetFoldedOverAnEdge) {
  Scene scene = gridScene(3, 3, 0.1, "backward_euler");
  Simulation sim = mustBuild(scene);
  Obstacle box;
  box.name = "block";
  box.shape.type = ShapeType::Box;
  box.shape.halfExtents = Eigen::Vector3d(0.1, 0.1, 0.1);
  ContactSettings settings;
  settings.distance = 2e-3;
  ContactModel contact(*sim.model, {box}, settings, 9.81);
  VectorX x(27);
  for (Index v = 0; v < 9; ++v) {
    const double y = -0.05 + 0.05 * (v % 3);
    const Eigen::Vector3d rows[3] = {{0.12, y, 0.05}, {0.05, y, 0.12}, {-0.05, y, 0.12}};
    x.segment<3>(3 * v) = rows[v / 3];
  }
  const std::vector<char> pinned(27, 0);
  contact.obstacles().beginStep(0.0, 0.01);
  contact.beginSubstep(x, x, 100.0, 0.01, pinned, 0.0, 1.0);
  contact.prepareSegment(x, VectorX::Zero(27));
  ContactStats stats;
  contact.finishSubstep(x, x, stats);
  EXPECT_NEAR(stats.boxDepth, 0.015, 1e-12);
  EXPECT_NE(stats.boxDepthWhere.find("in box 'block'"), std::string::npos) << stats.boxDepthWhere;
  // A triangle reaching into a box fails the substep, naming both (the step is then retried with
  // smaller substeps or fails; no state with it is accepted).
  EXPECT_NE(stats.crossing.find("reaches into box 'block'"), std::string::npos) << stats.crossing;
  EXPECT_EQ(stats.crossing.rfind("triangle ", 0), 0u) << stats.crossing;
  // Unfolded flat on the top (every point 2 cm above it): nothing inside.
  for (Index v = 0; v < 9; ++v) x[3 * v + 2] = 0.12;
  ContactStats flat;
  contact.beginSubstep(x, x, 100.0, 0.01, pinned, 0.0, 1.0);
  contact.prepareSegment(x, VectorX::Zero(27));
  contact.finishSubstep(x, x, flat);
  EXPECT_EQ(flat.boxDepth, 0.0);
  EXPECT_EQ(flat.crossing, "");
}

namespace {

// The largest sum_i lambda_i |p_i - x|^2 over the triangle (a, b, c), by brute force over a fine
// barycentric grid: the definition that latticeRadius() answers in closed form.
double bruteLatticeRadiusSquared(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  constexpr int n = 600;
  double best = 0.0;
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; i + j <= n; ++j) {
      const double l0 = static_cast<double>(i) / n, l1 = static_cast<double>(j) / n, l2 = 1.0 - l0 - l1;
      const Eigen::Vector3d x = l0 * a + l1 * b + l2 * c;
      best = std::max(best, l0 * (a - x).squaredNorm() + l1 * (b - x).squaredNorm() + l2 * (c - x).squaredNorm());
    }
  }
  return best;
}

// The smallest distance of the triangle's points to a round obstacle, by dense sampling
// (obstacle_check.h's shape, written out from its definition).
double denseTriangleDistance(const RoundObstacle& o, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                             const Eigen::Vector3d& c, int n = 300) {
  double best = 1e300;
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; i + j <= n; ++j) {
      const double l0 = static_cast<double>(i) / n, l1 = static_cast<double>(j) / n;
      best = std::min(best, o.distance(l0 * a + l1 * b + (1.0 - l0 - l1) * c, 0.0));
    }
  }
  return best;
}

}  // namespace

// rho of an equilateral triangle is its circumradius L / sqrt(3); of a right or obtuse one, half
// its longest side; and each matches the brute-force maximum of its definition.
TEST(ContactSurfaceSamples, LatticeRadiusMatchesClosedFormsAndItsDefinition) {
  const Eigen::Vector3d o = Eigen::Vector3d::Zero();
  const double L = 0.05;
  const Eigen::Vector3d e1(L, 0, 0), e2(0.5 * L, std::sqrt(3.0) / 2 * L, 0);
  EXPECT_NEAR(latticeRadius(o, e1, e2), L / std::sqrt(3.0), 1e-15);
  EXPECT_NEAR(latticeRadius(o, e1, Eigen::Vector3d(0, L, 0)), L / std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(latticeRadius(o, e1, Eigen::Vector3d(0.3 * L, 0.1 * L, 0.02 * L)), 0.5 * L, 1e-15);
  const std::vector<std::array<Eigen::Vector3d, 3>> triangles = {
      {o, e1, e2},
      {o, e1, Eigen::Vector3d(0, L, 0)},
      {o, e1, Eigen::Vector3d(0.3 * L, 0.1 * L, 0.02 * L)},
      {Eigen::Vector3d(0.01, -0.02, 0.03), Eigen::Vector3d(0.04, 0.01, 0.02), Eigen::Vector3d(0.0, 0.03, 0.05)},
  };
  for (const auto& t : triangles) {
    const double rho = latticeRadius(t[0], t[1], t[2]);
    EXPECT_NEAR(rho * rho, bruteLatticeRadiusSquared(t[0], t[1], t[2]), 1e-5 * rho * rho);  // the grid
  }
}

// Friction of the surface samples (lattice points) against a round obstacle: a stiff 10 cm
// plate, 4 x 4 vertices (columns 33 mm apart), balanced on a horizontal rod (a capsule of radius
// 5 mm along y) that runs under its centre line x = 5 cm, between two columns of vertices, so
// that only lattice points touch it (the nearest vertices clear the rod by 12 mm). Gravity is
// tilted along the rod by theta: by symmetry the contact is the rod's top line, its normal
// vertical, so Coulomb's law for the plate is the incline's: it sticks below the friction angle
// atan(mu) (creeping as IPC's smoothed friction does, below eps_v = 1e-3 m/s) and slides above with
// g (sin theta - mu cos theta). Without friction on the lattice points it slides at g sin theta.
TEST(ContactSurfaceSamples, PlateOnARodSticksBelowTheFrictionAngleAndSlidesAbove) {
  const double mu = 0.5, frictionAngle = std::atan(mu), side = 0.1, radius = 5e-3, dHat = 2e-3, epsV = 1e-3;
  const double kPi = std::acos(-1.0);
  for (const std::string integrator : {"backward_euler", "bdf2"}) {
    for (double offset : {-3.0, 3.0}) {
      const double theta = frictionAngle + offset * kPi / 180.0;
      Scene scene = gridScene(3, 4, side, integrator, 1000.0);
      scene.bendingStiffness = 1.0;  // N m: the plate stays flat, off the rod's sides
      scene.grid.origin = {0.0, 0.0, radius + 0.5 * dHat};
      SceneObstacle rod;
      rod.name = "rod";
      rod.type = ShapeType::Capsule;
      rod.center = Eigen::Vector3d(0.5 * side, 0.3, 0.0);
      rod.orientation = Eigen::Vector3d(0.0, 0.5 * kPi, 0.5 * kPi);  // the axis along y
      rod.radius = radius;
      rod.length = 1.0;
      rod.friction = mu;
      scene.obstacles = {rod};
      scene.contact.distance = dHat;
      scene.contact.frictionVelocity = epsV;
      scene.gravity = kG * Eigen::Vector3d(0.0, std::sin(theta), -std::cos(theta));
      Simulation sim = mustBuild(scene);
      const Simulator& s = *sim.simulator;
      const double t1 = 0.1, t2 = 0.5;
      double y1 = 0.0, v1 = 0.0;
      ASSERT_EQ(run(sim, static_cast<int>(std::lround(t2 / scene.dt)), [&](int n, const StepReport&) {
                  if (n == static_cast<int>(std::lround(t1 / scene.dt))) {
                    y1 = massMean(s.model(), s.state().x).y();
                    v1 = massMean(s.model(), s.state().v).y();
                  }
                }),
                "")
          << integrator;
      // The plate is still on the rod's top, level, and the vertices never touched it.
      const Eigen::Vector3d centre = massMean(s.model(), s.state().x);
      EXPECT_NEAR(centre.x(), 0.5 * side, 1e-4) << integrator;
      EXPECT_NEAR(centre.z(), radius + dHat, dHat) << integrator;
      const double moved = centre.y() - y1, v2 = massMean(s.model(), s.state().v).y();
      const double measured = (v2 - v1) / (t2 - t1);
      const double a = kG * (std::sin(theta) - mu * std::cos(theta));
      std::cout << integrator << ": " << theta * 180 / kPi << " deg (friction angle " << frictionAngle * 180 / kPi
                << " deg): moved " << moved << " m in " << t2 - t1 << " s, acceleration " << measured
                << " m/s^2 (Coulomb: " << std::max(a, 0.0) << ", frictionless: " << kG * std::sin(theta) << ")\n";
      if (a < 0) {
        // Sticking under the load ratio r = tan(theta) / mu: the creep of smoothed Coulomb,
        // eps_v (1 - sqrt(1 - r)) (test_core_contact, SticksWithTheCreepOfSmoothedCoulomb).
        const double creep = epsV * (1.0 - std::sqrt(1.0 - std::tan(theta) / mu));
        EXPECT_NEAR(moved / (t2 - t1), creep, 0.05 * creep) << integrator;
      } else {
        EXPECT_NEAR(measured, a, 0.05 * a) << integrator;
      }
    }
  }
}

// The lattice of k divisions: k - 1 points inside each edge and (k - 1)(k - 2)/2 inside each
// triangle, counted by hand for the two triangles of a unit square (5 edges), each a convex
// combination of its vertices lying on the lattice (coordinates multiples of 1/k).
TEST(ContactSurfaceSamples, LatticeOfTwoTriangles) {
  Mesh mesh;
  mesh.restPositions.resize(12);
  mesh.restPositions << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0;
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  const VectorX mass = VectorX::Constant(4, 0.25);
  EXPECT_TRUE(surfaceSamples(mesh, mass, 1).empty());
  for (int k : {2, 3, 5}) {
    const std::vector<SurfaceSample> samples = surfaceSamples(mesh, mass, k);
    ASSERT_EQ(samples.size(), static_cast<std::size_t>(5 * (k - 1) + 2 * (k - 1) * (k - 2) / 2)) << k;
    for (const SurfaceSample& s : samples) {
      EXPECT_NEAR(s.weights.head(s.count).sum(), 1.0, 1e-15);
      EXPECT_TRUE((s.weights.head(s.count).array() > 0.0).all());
      const Eigen::Vector3d w = s.weights * k;
      EXPECT_NEAR((w - w.array().round().matrix()).norm(), 0.0, 1e-12);
      EXPECT_NEAR(s.mass, 0.25, 1e-15);  // the weighted mean of its vertices' masses
    }
  }
}

// The promise of surface_samples.h, checked by dense sampling: a triangle whose lattice points
// all lie outside a sphere (or capsule) grown by inflation(r, rho / k) has no point inside the
// shape itself; and the bound is nearly tight: with the worst lattice cell centred over the
// shape, the triangle comes within a small fraction of the inflation of touching it.
TEST(ContactSurfaceSamples, LatticeOutsideTheGrownShapeKeepsTheTriangleOutside) {
  const Eigen::Vector3d a(0, 0, 0), b(0.06, 0, 0), c(0.025, 0.05, 0);
  for (const double radius : {0.25, 0.02}) {
    for (const int k : {1, 2, 4}) {
      const double rho = latticeRadius(a, b, c) / k;
      const double grow = inflation(radius, rho);
      // The sub-triangle at the corner a: its circumcentre (acute), straight under which the
      // shape's core sits; then lifted until its nearest lattice point is at r + grow.
      const Eigen::Vector3d sa = a, sb = a + (b - a) / k, sc = a + (c - a) / k;
      const Eigen::Vector3d n = (sb - sa).cross(sc - sa).normalized();
      const Eigen::Vector3d ab = sb - sa, ac = sc - sa;
      const Eigen::Vector3d centre =
          sa + ((ab.squaredNorm() * ac - ac.squaredNorm() * ab).cross(ab.cross(ac))) / (2.0 * ab.cross(ac).squaredNorm());
      RoundObstacle shape;
      shape.radius = radius;
      shape.axis = Eigen::Vector3d(1, 1, 0).normalized();  // the capsule's axis along the plane
      for (const double halfLength : {0.0, 0.1}) {
        shape.halfLength = halfLength;
        // Lattice points of the whole triangle, and the height that puts the nearest at r + grow.
        std::vector<Eigen::Vector3d> lattice;
        for (int i = 0; i <= k; ++i) {
          for (int j = 0; i + j <= k; ++j) lattice.push_back(a + (b - a) * i / k + (c - a) * j / k);
        }
        double lo = 0.0, hi = 1.0;
        for (int it = 0; it < 100; ++it) {
          const double mid = 0.5 * (lo + hi);
          shape.center = centre - mid * n;
          double nearest = 1e300;
          for (const auto& p : lattice) nearest = std::min(nearest, shape.distance(p, 0.0));
          (nearest > grow ? hi : lo) = mid;
        }
        shape.center = centre - hi * n;
        const double d = denseTriangleDistance(shape, a, b, c);
        EXPECT_GE(d, -1e-12) << "radius " << radius << ", k " << k << ", half length " << halfLength;
        // For the sphere the bound is tight (the cell's circumcentre ends on the sphere); a
        // capsule's axis lying along the triangle curves less, so it keeps more room.
        if (halfLength == 0.0) {
          EXPECT_LT(d, 0.25 * grow) << "radius " << radius << ", k " << k;
        }
      }
    }
  }
}

// The exact triangle distance that finishSubstep checks the samples' promise with, against dense
// sampling: a sphere under a triangle's interior, a capsule across it, a capsule through it.
TEST(ContactSurfaceSamples, TriangleShapeDistanceMatchesDenseSampling) {
  const Eigen::Vector3d a(-0.05, -0.04, 0.0), b(0.06, -0.03, 0.01), c(0.0, 0.07, -0.01);
  struct Case {
    const char* what;
    Eigen::Vector3d center;
    Eigen::Vector3d axis;
    double halfLength, radius;
  };
  const std::vector<Case> cases = {
      {"sphere under the interior", {0.01, 0.0, -0.3}, Eigen::Vector3d::UnitZ(), 0.0, 0.29},
      {"sphere beside an edge", {0.0, -0.2, 0.0}, Eigen::Vector3d::UnitZ(), 0.0, 0.1},
      {"capsule across, below", {0.0, 0.0, -0.03}, Eigen::Vector3d(1, 0.3, 0).normalized(), 0.3, 0.02},
      {"capsule end cap under the interior", {0.0, 0.0, -0.35}, Eigen::Vector3d::UnitZ(), 0.3, 0.02},
      {"capsule through the triangle", {0.0, 0.0, 0.0}, Eigen::Vector3d(0.1, 0.2, 1).normalized(), 0.3, 0.02},
  };
  for (const Case& cs : cases) {
    RoundObstacle o;
    o.center = cs.center;
    o.axis = cs.axis;
    o.halfLength = cs.halfLength;
    o.radius = cs.radius;
    // The same shape in its own frame: centre at the origin, axis along z.
    Shape shape;
    shape.type = cs.halfLength > 0.0 ? ShapeType::Capsule : ShapeType::Sphere;
    shape.radius = cs.radius;
    shape.halfLength = cs.halfLength;
    const Eigen::Quaterniond toLocal = Eigen::Quaterniond::FromTwoVectors(cs.axis, Eigen::Vector3d::UnitZ());
    auto local = [&](const Eigen::Vector3d& p) { return Eigen::Vector3d(toLocal * (p - cs.center)); };
    const double exact = *triangleShapeDistance(shape, local(a), local(b), local(c));
    const double dense = denseTriangleDistance(o, a, b, c, 600);
    if (dense < 0.0) {
      EXPECT_LT(exact, 0.0) << cs.what;
    } else {
      EXPECT_LE(exact, dense + 1e-12) << cs.what;
      EXPECT_NEAR(exact, dense, 2e-4) << cs.what;  // the grid's spacing, 0.1 mm, bounds the gap
    }
  }
}
