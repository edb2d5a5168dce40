// The exact depth of a triangle in a box (surface_check.h) against hand cases and an independent
// dense barycentric sampling written out here from the definition (the depth of a point p is
// min_i (h_i - |p_i|)).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <random>

#include "fem_cloth/core/contact/surface_check.h"

using namespace fem_cloth;

namespace {

const Eigen::Vector3d kUnit(1.0, 1.0, 1.0);

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
  std::uniform_real_distribution<double> coordinate(-1.6, 1.6), extent(0.3, 1.2);
  constexpr int n = 150;
  int inside = 0, outside = 0;
  double worstGap = 0.0;
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::Vector3d h(extent(rng), extent(rng), extent(rng));
    const Eigen::Vector3d a(coordinate(rng), coordinate(rng), coordinate(rng));
    const Eigen::Vector3d b(coordinate(rng), coordinate(rng), coordinate(rng));
    const Eigen::Vector3d c(coordinate(rng), coordinate(rng), coordinate(rng));
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
