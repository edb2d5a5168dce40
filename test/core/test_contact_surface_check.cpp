// The exact depth of a triangle in a box (surface_check.h) against hand cases and an independent
// dense barycentric sampling written out here from the definition (the depth of a point p is
// min_i (h_i - |p_i|)), and the explicit steppers' surface check (projection_contact.h) that uses
// it: boxes reported through ContactStats::boxDepth, round obstacles failing the substep.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <random>

#include "fem_cloth/core/contact/edge_distance.h"
#include "fem_cloth/core/contact/projection_contact.h"
#include "fem_cloth/core/contact/surface_check.h"
#include "fem_cloth/core/contact/surface_reach.h"
#include "fem_cloth/core/contact/surface_samples.h"
#include "config_scene.h"
#include "test_support.h"

using namespace fem_cloth;
using namespace fem_cloth::test;

namespace {

const Eigen::Vector3d kUnit(1.0, 1.0, 1.0);
const double kPi = std::acos(-1.0);

// The definition, point by point.
double pointDepth(const Eigen::Vector3d& h, const Eigen::Vector3d& p) {
  return std::min({h.x() - std::abs(p.x()), h.y() - std::abs(p.y()), h.z() - std::abs(p.z())});
}

// The largest depth over a grid of n divisions of the triangle's barycentric coordinates.
double sampledDepth(const Eigen::Vector3d& h, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                    const Eigen::Vector3d& c, int n) {
  double best = -1e300;
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; i + j <= n; ++j) {
      const double l0 = static_cast<double>(i) / n, l1 = static_cast<double>(j) / n;
      best = std::max(best, pointDepth(h, l0 * a + l1 * b + (1.0 - l0 - l1) * c));
    }
  }
  return best;
}

// A random box centred at the origin (half extents 0.3 to 1.2 m) and triangle (coordinates
// within 1.6 m of the centre): about four in five reach into the box.
struct RandomCase {
  Eigen::Vector3d h, a, b, c;
};

RandomCase randomCase(std::mt19937& rng) {
  std::uniform_real_distribution<double> coordinate(-1.6, 1.6), extent(0.3, 1.2);
  RandomCase r;
  r.h = Eigen::Vector3d(extent(rng), extent(rng), extent(rng));
  for (Eigen::Vector3d* p : {&r.a, &r.b, &r.c}) *p = Eigen::Vector3d(coordinate(rng), coordinate(rng), coordinate(rng));
  return r;
}

}  // namespace

// A triangle in the plane of the top face, within it: its points are on the surface, depth 0;
// lifted 1 cm, -1 cm (every point 1 cm above the top).
TEST(TriangleBoxDepth, TriangleInAFacePlane) {
  const Eigen::Vector3d a(-0.5, -0.5, 1.0), b(0.5, -0.5, 1.0), c(0.0, 0.5, 1.0), up(0.0, 0.0, 0.01);
  EXPECT_NEAR(triangleBoxDepth(kUnit, a, b, c), 0.0, 1e-15);
  EXPECT_NEAR(triangleBoxDepth(kUnit, a + up, b + up, c + up), -0.01, 1e-15);
  EXPECT_TRUE(triangleBeyondAFace(kUnit, a + up, b + up, c + up));
  EXPECT_FALSE(triangleBeyondAFace(kUnit, a, b, c));
}

// A triangle in the plane x + z = 1.9 across the box's edge x = z = 1, its three vertices
// outside (x or z = 1.45). On that plane min(1 - x, 1 - z) <= (2 - x - z) / 2 = 0.05, reached at
// x = z = 0.95 (y = 0: 1 - |y| = 1), which is on the triangle (the median from a): 0.05 m.
TEST(TriangleBoxDepth, TrianglePiercedByAnEdge) {
  const Eigen::Vector3d a(1.45, 0.0, 0.45), b(0.45, -0.5, 1.45), c(0.45, 0.5, 1.45);
  EXPECT_LT(pointDepth(kUnit, a), 0.0);
  EXPECT_LT(pointDepth(kUnit, b), 0.0);
  EXPECT_LT(pointDepth(kUnit, c), 0.0);
  EXPECT_NEAR(triangleBoxDepth(kUnit, a, b, c), 0.05, 1e-14);
}

// The corner (1, 1, 1) poking through the middle of a big triangle in the plane x + y + z = 2.7,
// centred on (0.9, 0.9, 0.9), whose vertices are all 1.9 m outside: on that plane
// min(1 - x, 1 - y, 1 - z) <= (3 - 2.7) / 3 = 0.1, reached at the centre: 0.1 m.
TEST(TriangleBoxDepth, CornerThroughTheMiddleOfABigTriangle) {
  const Eigen::Vector3d centre(0.9, 0.9, 0.9);
  const Eigen::Vector3d a = centre + Eigen::Vector3d(2, -1, -1), b = centre + Eigen::Vector3d(-1, 2, -1),
                        c = centre + Eigen::Vector3d(-1, -1, 2);
  EXPECT_NEAR(pointDepth(kUnit, a), -1.9, 1e-14);
  EXPECT_NEAR(triangleBoxDepth(kUnit, a, b, c), 0.1, 1e-14);
  EXPECT_FALSE(triangleBeyondAFace(kUnit, a, b, c));
}

// Inside a box of half extents (1, 2, 3): x binds, and the smallest |x| on the triangle is
// 0.2 at a, where y and z leave 2 and 3: 0.8 m.
TEST(TriangleBoxDepth, TriangleFullyInside) {
  const Eigen::Vector3d h(1.0, 2.0, 3.0), a(0.2, 0.0, 0.0), b(0.6, 0.1, 0.0), c(0.4, -0.2, 0.3);
  EXPECT_NEAR(triangleBoxDepth(h, a, b, c), 0.8, 1e-15);
}

// Far: the nearest point a = (5, 5, 5) is 4 m beyond each face plane: -4, minus the distance in
// the maximum norm (the Euclidean one is 4 sqrt(3)).
TEST(TriangleBoxDepth, FarTriangle) {
  const Eigen::Vector3d a(5, 5, 5), b(6, 5, 5), c(5, 6, 5);
  EXPECT_NEAR(triangleBoxDepth(kUnit, a, b, c), -4.0, 1e-14);
  EXPECT_TRUE(triangleBeyondAFace(kUnit, a, b, c));
}

// Random triangles against random boxes: the sampled maximum never exceeds the exact one, and
// falls short by at most the grid's resolution: the depth changes by at most |p - q| between two
// points (each |p_i| by at most |p_i - q_i|), and every point of the triangle is within a grid
// cell's diameter, longest side / n, of a grid point.
TEST(TriangleBoxDepth, MatchesDenseSampling) {
  std::mt19937 rng(30);
  constexpr int n = 150;
  int inside = 0, outside = 0;
  double worstGap = 0.0;
  for (int trial = 0; trial < 300; ++trial) {
    const RandomCase r = randomCase(rng);
    const Eigen::Vector3d &h = r.h, &a = r.a, &b = r.b, &c = r.c;
    const double exact = triangleBoxDepth(h, a, b, c);
    const double sampled = sampledDepth(h, a, b, c, n);
    const double side = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
    EXPECT_LE(sampled, exact + 1e-12) << "trial " << trial;
    EXPECT_GE(sampled, exact - side / n - 1e-12) << "trial " << trial;
    worstGap = std::max(worstGap, (exact - sampled) / (side / n));
    if (triangleBeyondAFace(h, a, b, c)) {
      EXPECT_LT(exact, 0.0) << "trial " << trial;
    }
    (exact > 0.0 ? inside : outside) += 1;
  }
  // Both kinds were tried.
  EXPECT_GT(inside, 50);
  EXPECT_GT(outside, 20);
  std::cout << inside << " triangles reaching into their box, " << outside
            << " not; the largest gap to the sampling, in units of its bound: " << worstGap << "\n";
}

// The hand triangle across the edge x = z = 1 moved 0.1 m outward along x and z: in the plane
// x + z = 2.1, beyond the box's x + z <= 2 (-0.05 in the maximum norm), and no face's plane
// has it all beyond: the triangle's normal separates it.
TEST(TriangleSeparatedFromBox, TheTrianglesNormalSeparatesWhatNoFaceDoes) {
  const Eigen::Vector3d a(1.55, 0.0, 0.55), b(0.55, -0.5, 1.55), c(0.55, 0.5, 1.55);
  EXPECT_FALSE(triangleBeyondAFace(kUnit, a, b, c));
  EXPECT_TRUE(triangleSeparatedFromBox(kUnit, a, b, c));
  EXPECT_NEAR(triangleBoxDepth(kUnit, a, b, c), -0.05, 1e-14);
  // Shrunk by the depth of the unmoved triangle (0.05), it is separated from that one too, and
  // not from the box shrunk by less.
  const Eigen::Vector3d in(0.1, 0.0, 0.1);
  EXPECT_TRUE(triangleSeparatedFromBox(kUnit.array() - 0.05, a - in, b - in, c - in));
  EXPECT_FALSE(triangleSeparatedFromBox(kUnit.array() - 0.049, a - in, b - in, c - in));
  EXPECT_TRUE(triangleSeparatedFromBox(Eigen::Vector3d(1.0, 0.0, 1.0), a - in, b - in, c - in)) << "an empty box";
}

// The separating axis test agrees with the exact depth on random triangles: separated from the
// box shrunk by d exactly when the depth is at most d (up to rounding), for d = 0 and d = 0.1.
TEST(TriangleSeparatedFromBox, AgreesWithTheExactDepth) {
  std::mt19937 rng(31);
  int separated = 0, notSeparated = 0, notByAFace = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const RandomCase r = randomCase(rng);
    const Eigen::Vector3d &h = r.h, &a = r.a, &b = r.b, &c = r.c;
    const double exact = triangleBoxDepth(h, a, b, c);
    for (const double d : {0.0, 0.1}) {
      const Eigen::Vector3d shrunk = h.array() - d;
      if (triangleSeparatedFromBox(shrunk, a, b, c)) {
        EXPECT_LE(exact, d + 1e-12) << "trial " << trial << ", d " << d;
        ++separated;
        if (!triangleBeyondAFace(shrunk, a, b, c)) ++notByAFace;
      } else {
        EXPECT_GE(exact, d - 1e-12) << "trial " << trial << ", d " << d;
        ++notSeparated;
      }
    }
  }
  EXPECT_GT(notSeparated, 500);
  EXPECT_GT(notByAFace, 100) << "the normal and the cross axes were tried";
  std::cout << separated << " separated (" << notByAFace << " not by a face), " << notSeparated << " not\n";
}

namespace {

struct Projection {
  Simulation sim;
  std::shared_ptr<ObstacleSet> obstacles;
  std::unique_ptr<ProjectionContact> contact;
};

// A 3 x 3 sheet (side 0.1 m) and the explicit steppers' contact against one obstacle, 2 mm d̂,
// failing a substep with a point deeper than `tolerance` (m) in it.
Projection projection(const Obstacle& obstacle, double tolerance) {
  Projection p{mustBuild(gridScene(3, 3, 0.1, "symplectic_euler")), nullptr, nullptr};
  ContactSettings settings;
  settings.distance = 2e-3;
  settings.surfaceTolerance = tolerance;
  p.obstacles = std::make_shared<ObstacleSet>(std::vector<Obstacle>{obstacle});
  p.contact = std::make_unique<ProjectionContact>(*p.sim.model, p.obstacles, settings);
  return p;
}

// One substep of 0.01 s ending at x (which no vertex of is within d̂ of the obstacle).
ContactStats substep(Projection& p, VectorX x, const std::vector<char>& pinned) {
  p.obstacles->beginStep(0.0, 0.01);
  p.contact->beginSubstep(0.0, 1.0);
  EXPECT_EQ(p.contact->project(x, x, pinned), 0);
  ContactStats stats;
  p.contact->finishSubstep(x, x, 0.01, 1.0, stats);
  return stats;
}

}  // namespace

// The sheet folded over the box's edge (x = z = 0.1 m): its first row at x = 0.13, z = 0.05
// (3 cm outside the +x face), its second at x = 0.05, z = 0.12 (2 cm above the top), its third at
// x = -0.05, z = 0.12. Between the first two rows the point at the fraction t has
// x = 0.13 - 0.08 t, z = 0.05 + 0.07 t: its depth min(0.1 - x, 0.1 - z) (|y| <= 0.05 leaves
// 0.05 or more) is largest where 0.08 t - 0.03 = 0.05 - 0.07 t, t = 8/15: 0.19/15 m = 12.67 mm
// by hand (a grid of tenths of the way finds 10 mm at best): within a tolerance of 20 mm it is
// reported, beyond one of 10 mm the substep fails naming the triangle and the box. Pinning the
// first row takes every triangle between the first two rows out of the check (the pin wins):
// nothing.
TEST(ProjectionSurfaceCheck, ExactBoxDepthOfASheetFoldedOverAnEdge) {
  Obstacle box;
  box.name = "block";
  box.shape.type = ShapeType::Box;
  box.shape.halfExtents = Eigen::Vector3d(0.1, 0.1, 0.1);
  Projection p = projection(box, 0.02);
  VectorX x(27);
  for (Index v = 0; v < 9; ++v) {
    const double y = -0.05 + 0.05 * (v % 3);
    const Eigen::Vector3d rows[3] = {{0.13, y, 0.05}, {0.05, y, 0.12}, {-0.05, y, 0.12}};
    x.segment<3>(3 * v) = rows[v / 3];
  }
  std::vector<char> pinned(27, 0);
  const ContactStats stats = substep(p, x, pinned);
  EXPECT_NEAR(stats.boxDepth, 0.19 / 15, 1e-15);
  EXPECT_NE(stats.boxDepthWhere.find("in box 'block'"), std::string::npos) << stats.boxDepthWhere;
  EXPECT_TRUE(stats.crossing.empty()) << stats.crossing;  // within the tolerance: reported
  Projection strict = projection(box, 0.01);
  const ContactStats failed = substep(strict, x, pinned);
  EXPECT_NEAR(failed.boxDepth, 0.19 / 15, 1e-15);
  EXPECT_NE(failed.crossing.find(" is 12.667 mm inside box 'block' (moving at 0 m/s), more than "
                                 "contact.surface_tolerance (10.000 mm)"),
            std::string::npos)
      << failed.crossing;
  std::fill(pinned.begin(), pinned.begin() + 9, 1);
  EXPECT_EQ(substep(p, x, pinned).boxDepth, 0.0);
}

// A flat sheet at z = 0 and a 2 cm ball centred on the centroid of one of its triangles: the
// triangle's vertices are outside (the centroid of a right triangle with 5 cm legs is
// sqrt(5) / 3 x 5 cm = 3.7 cm from its farthest vertex, sqrt(2) x 5 cm / 3 = 2.36 cm from the
// others), but its middle is the radius, 20 mm, inside: more than a tolerance of 10 mm, the
// substep fails naming the triangle and the ball. 1.5 cm lower the ball reaches 5 mm into
// the sheet, within the tolerance: no failure, but the depth is measured and reported (as a
// box's), 5 mm into triangle 0 (the deepest; the ball's top is in its middle).
TEST(ProjectionSurfaceCheck, BallThroughATriangleBetweenItsVertices) {
  Obstacle ball;
  ball.name = "ball";
  ball.shape.type = ShapeType::Sphere;
  ball.shape.radius = 0.02;
  Projection p0 = projection(ball, 0.01);
  const Triangle tri = p0.sim.model->mesh().triangles[0];
  VectorX x = p0.sim.simulator->state().x;
  for (Index v = 0; v < 9; ++v) x[3 * v + 2] = 0.0;
  const Eigen::Vector3d centroid =
      (x.segment<3>(3 * tri[0]) + x.segment<3>(3 * tri[1]) + x.segment<3>(3 * tri[2])) / 3.0;
  for (Index v = 0; v < 9; ++v) ASSERT_GT((x.segment<3>(3 * v) - centroid).norm(), 0.02) << "vertex " << v;
  ball.geometry.translation() = centroid;
  Projection p = projection(ball, 0.01);
  const std::vector<char> pinned(27, 0);
  const ContactStats through = substep(p, x, pinned);
  EXPECT_NE(through.crossing.find("triangle 0 (vertices "), std::string::npos) << through.crossing;
  EXPECT_NE(through.crossing.find("is 20.000 mm inside sphere 'ball' (moving at 0 m/s), more than contact.surface_tolerance (10.000 mm)"),
            std::string::npos)
      << through.crossing;
  EXPECT_NEAR(through.boxDepth, 0.02, 1e-12);
  ball.geometry.translation() = centroid - Eigen::Vector3d(0.0, 0.0, 0.015);
  Projection lower = projection(ball, 0.01);
  const ContactStats shallow = substep(lower, x, pinned);
  EXPECT_TRUE(shallow.crossing.empty()) << shallow.crossing;
  EXPECT_NEAR(shallow.boxDepth, 0.005, 1e-12);
  EXPECT_EQ(shallow.boxDepthWhere, "triangle 0 in sphere 'ball'");
}

// The bound before a run (surface_reach.h), built by hand: an equilateral triangle in the plane
// z = hz over a ball of radius r centred at the origin, its centroid on the z axis and its
// vertices on the ball grown by d̂ (so the projection would leave them there): by Pythagoras its
// circumradius is sqrt((r + d̂)^2 - hz^2), and its deepest point, the centroid, is r - hz inside.
// The bound is that depth (it is reached). Then 20000 random triangles with every vertex at least
// d̂ outside a sphere, a capsule or a box (each triangle's depth computed exactly by
// triangleShapeDistance / triangleBoxDepth): none goes deeper than the bound for its lattice
// radius, and the deepest come within 15 % of it (the bound is not loose).
TEST(SurfaceReach, BoundIsReachedAndNeverExceeded) {
  const double r = 0.1, dHat = 0.002;
  Shape ball;
  ball.type = ShapeType::Sphere;
  ball.radius = r;
  for (double hz : {0.1, 0.09, 0.07, 0.03}) {
    const double circum = std::sqrt((r + dHat) * (r + dHat) - hz * hz);
    Eigen::Vector3d v[3];
    for (int i = 0; i < 3; ++i) {
      const double a = 2.0 * kPi * i / 3.0;
      v[i] = Eigen::Vector3d(circum * std::cos(a), circum * std::sin(a), hz);
      ASSERT_NEAR(v[i].norm(), r + dHat, 1e-12);
    }
    const double depth = -*triangleShapeDistance(ball, v[0], v[1], v[2]);
    EXPECT_NEAR(depth, r - hz, 1e-12) << "plane at " << hz;
    EXPECT_NEAR(surfaceReachBound(ball, latticeRadius(v[0], v[1], v[2]), dHat), r - hz, 1e-12) << "plane at " << hz;
  }
  // The ball passes through a triangle whose vertices are all r + d̂ from its centre in its plane:
  // any depth up to its radius.
  bool through = false;
  EXPECT_EQ(surfaceReachBound(ball, r + dHat, dHat, &through), r);
  EXPECT_TRUE(through);

  Shape capsule;
  capsule.type = ShapeType::Capsule;
  capsule.radius = 0.05;
  capsule.halfLength = 0.2;
  Shape box;
  box.type = ShapeType::Box;
  box.halfExtents = Eigen::Vector3d(0.3, 0.2, 0.15);
  std::mt19937 rng(30);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), size(0.01, 0.12), offset(-0.03, 0.01);
  auto randomDirection = [&] {
    Eigen::Vector3d d;
    do d = Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    while (d.squaredNorm() > 1.0 || d.squaredNorm() < 1e-6);
    return d.normalized();
  };
  for (const Shape* shape : {&ball, &capsule, &box}) {
    int tried = 0, inside = 0;
    double closest = 0.0;  // the largest depth / bound seen
    while (tried < 20000) {
      // A centre near the surface (up to 3 cm in, 1 cm out) and three vertices around it, each
      // at least d̂ outside.
      const SignedDistance near = signedDistance(*shape, 0.45 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng)));
      const Eigen::Vector3d centre = near.closest + offset(rng) * near.normal;
      const double spread = size(rng);
      Eigen::Vector3d v[3];
      bool placed = true;
      for (Eigen::Vector3d& p : v) {
        int attempts = 0;
        do p = centre + spread * randomDirection();
        while (signedDistance(*shape, p).distance < dHat && ++attempts < 50);
        placed = placed && attempts < 50;
      }
      if (!placed) continue;
      const double rho = latticeRadius(v[0], v[1], v[2]);
      bool passes = false;
      const double bound = surfaceReachBound(*shape, rho, dHat, &passes);
      if (passes) continue;
      ++tried;
      const double depth = shape->type == ShapeType::Box ? triangleBoxDepth(shape->halfExtents, v[0], v[1], v[2])
                                                         : -*triangleShapeDistance(*shape, v[0], v[1], v[2]);
      if (depth <= 0.0) continue;
      ++inside;
      ASSERT_LE(depth, bound + 1e-12) << shapeTypeName(shape->type) << ": lattice radius " << rho;
      closest = std::max(closest, depth / bound);
    }
    std::cout << shapeTypeName(shape->type) << ": " << inside << " of " << tried
              << " triangles reach in; the deepest is " << closest << " of its bound\n";
    EXPECT_GT(inside, 1000) << shapeTypeName(shape->type);
  }
}

// The refusal, as a user meets it (issue 30, finding 2): the explicit steppers keep vertices out,
// so a scene whose triangles could reach deeper into an obstacle than contact.surface_tolerance
// is refused before the run. By hand, config/table_drape.yaml: 21 x 21 vertices on 0.8 m, right
// triangles with 4 cm legs, lattice radius (half the hypotenuse) 28.28 mm, at the default
// contact.surface_stretch 1.5 42.43 mm; into the box's sharp edge 42.43 - 2 (d̂) = 40.43 mm. The
// hint's 0.0405 m lets it run; backward Euler needs no tolerance. test/data/contact/ball.yaml:
// 13 x 13 on 1 m, lattice radius 1.5 x 58.93 = 88.39 mm, the 0.1 m ball grown by 2 mm: 100 -
// sqrt(102^2 - 88.39^2) = 49.09 mm. rod.yaml's 2 cm rod passes between vertices (88.39 > 22 mm).
// config/fold.yaml (a floor only) is accepted.
TEST(SurfaceReach, ExplicitSteppersRefuseTrianglesThatCouldReachIntoAnObstacle) {
  for (const std::string integrator : {"symplectic_euler", "xpbd"}) {
    Scene table = configScene("table_drape.yaml");
    table.integrator = integrator;
    const Status refused = validateScene(table);
    ASSERT_FALSE(refused.ok()) << integrator;
    for (const std::string& part :
         {"obstacles: integrator " + integrator + " does not support keeping the cloth's surface out of box 'table'",
         std::string("(points up to 42.43 mm from its nearest vertex at contact.surface_stretch 1.5) may reach up to "
                     "40.43 mm into it, more than contact.surface_tolerance (2.00 mm)"),
         std::string("set contact.surface_tolerance: 0.0405 to accept that depth"),
         std::string("choose an integrator that does: backward_euler, bdf2")}) {
      EXPECT_NE(refused.error().find(part), std::string::npos) << refused.error();
    }
    table.contact.surfaceTolerance = 0.0405;
    EXPECT_TRUE(validateScene(table).ok()) << validateScene(table).error();
    table.contact.surfaceTolerance = 0.0404;
    EXPECT_FALSE(validateScene(table).ok());

    Expected<Scene> ball = loadScene(std::string(FEM_CLOTH_TEST_DATA_DIR) + "/contact/ball.yaml");
    ASSERT_TRUE(ball.ok()) << ball.error();
    ball->integrator = integrator;
    const Status ballRefused = validateScene(*ball);
    ASSERT_FALSE(ballRefused.ok());
    EXPECT_NE(ballRefused.error().find("sphere 'ball'"), std::string::npos) << ballRefused.error();
    EXPECT_NE(ballRefused.error().find("may reach up to 49.09 mm into it"), std::string::npos) << ballRefused.error();

    Expected<Scene> rod = loadScene(std::string(FEM_CLOTH_TEST_DATA_DIR) + "/contact/rod.yaml");
    ASSERT_TRUE(rod.ok()) << rod.error();
    rod->integrator = integrator;
    rod->contact.surfaceTolerance = 0.0199;  // a rod passing through: only its radius accepts it
    const Status rodRefused = validateScene(*rod);
    ASSERT_FALSE(rodRefused.ok());
    EXPECT_NE(rodRefused.error().find("is wide enough for the obstacle to pass between its vertices"), std::string::npos)
        << rodRefused.error();
    EXPECT_NE(rodRefused.error().find("refine the mesh: its triangles' points must stay within 22.00 mm of a vertex"),
              std::string::npos)
        << rodRefused.error();
    rod->contact.surfaceTolerance = 0.02;  // the rod's radius: any depth
    EXPECT_TRUE(validateScene(*rod).ok()) << validateScene(*rod).error();

    Scene fold = configScene("fold.yaml");
    fold.integrator = integrator;
    fold.contact.selfCollision = false;
    EXPECT_TRUE(validateScene(fold).ok()) << validateScene(fold).error();
  }
  Scene table = configScene("table_drape.yaml");
  table.integrator = "backward_euler";
  EXPECT_TRUE(validateScene(table).ok()) << validateScene(table).error();
}
