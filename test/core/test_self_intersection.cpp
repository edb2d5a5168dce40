// Self-intersection of a cloth mesh (contact/self_intersection.h): segment-triangle crossings
// against an independent computation (the crossing point solved as a 3 x 3 linear system in the
// segment's and the triangle's parameters), whole meshes against brute force over all pairs,
// and a 129 x 129 cloth, flat, folded and pierced, through the broad phase.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

#include "fem_cloth/core/contact/self_intersection.h"

using namespace fem_cloth;

namespace {

std::mt19937 rng(11);
double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); }
Eigen::Vector3d randomPoint() { return Eigen::Vector3d(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)); }

// p + t (q - p) = a + u (b - a) + v (c - a), solved for (t, u, v). `clear` is how far the
// solution is from every boundary of the crossing region (0 < t < 1, u > 0, v > 0, u + v < 1);
// negative when it is outside.
struct Crossing {
  bool crosses = false;
  double clear = 0.0;
};
Crossing solveCrossing(const Eigen::Vector3d& p, const Eigen::Vector3d& q, const Eigen::Vector3d& a,
                       const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  Eigen::Matrix3d A;
  A << -(q - p), b - a, c - a;
  const Eigen::Vector3d tuv = A.fullPivLu().solve(p - a);
  const double clear = std::min({tuv[0], 1.0 - tuv[0], tuv[1], tuv[2], 1.0 - tuv[1] - tuv[2]});
  return {clear > 0.0, clear};
}

// Every pair of triangles sharing no edge, every edge of one that does not touch the other.
bool bruteForceIntersects(const Mesh& mesh, const VectorX& x, double* closest) {
  auto at = [&x](Index v) -> Eigen::Vector3d { return x.segment<3>(3 * v); };
  bool any = false;
  *closest = 1.0;
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    for (std::size_t j = 0; j < mesh.triangles.size(); ++j) {
      if (i == j) continue;
      const Triangle& e = mesh.triangles[i];
      const Triangle& t = mesh.triangles[j];
      int shared = 0;
      for (Index a : e) shared += (a == t[0]) + (a == t[1]) + (a == t[2]);
      if (shared >= 2) continue;
      for (int k = 0; k < 3; ++k) {
        const Index p = e[k], q = e[(k + 1) % 3];
        if (p == t[0] || p == t[1] || p == t[2] || q == t[0] || q == t[1] || q == t[2]) continue;
        const Crossing c = solveCrossing(at(p), at(q), at(t[0]), at(t[1]), at(t[2]));
        *closest = std::min(*closest, std::abs(c.clear));
        any = any || c.crosses;
      }
    }
  }
  return any;
}

Mesh grid(int n, double side) {
  GridSpec spec;
  spec.rows = spec.cols = n;
  spec.width = spec.height = side;
  return *makeGrid(spec);
}

}  // namespace

TEST(SelfIntersection, SegmentCrossingsAgreeWithTheLinearSolve) {
  int crossings = 0, compared = 0;
  for (int sample = 0; sample < 20000; ++sample) {
    const Eigen::Vector3d p = randomPoint(), q = randomPoint(), a = randomPoint(), b = randomPoint(),
                          c = randomPoint();
    const Crossing expected = solveCrossing(p, q, a, b, c);
    if (std::abs(expected.clear) < 1e-6) continue;  // too close to a boundary to call
    ++compared;
    crossings += expected.crosses;
    EXPECT_EQ(segmentCrossesTriangle(p, q, a, b, c), expected.crosses) << "sample " << sample;
    // Neither the direction of the segment nor the order of the corners matters.
    EXPECT_EQ(segmentCrossesTriangle(q, p, c, b, a), expected.crosses) << "sample " << sample;
  }
  EXPECT_GT(compared, 19000);
  EXPECT_GT(crossings, 500) << "the samples must cross often enough to test anything";
}

TEST(SelfIntersection, TouchingAndCoplanarAreNoCrossings) {
  const Eigen::Vector3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  // Ends on the triangle, and lying in its plane: zero distance, which the contact distance
  // check refuses; not a crossing here.
  EXPECT_FALSE(segmentCrossesTriangle({0.2, 0.2, 0}, {0.2, 0.2, 1}, a, b, c));
  EXPECT_FALSE(segmentCrossesTriangle({-1, 0.2, 0}, {2, 0.2, 0}, a, b, c));
  // Through an edge or a corner.
  EXPECT_FALSE(segmentCrossesTriangle({0.5, 0, -1}, {0.5, 0, 1}, a, b, c));
  EXPECT_FALSE(segmentCrossesTriangle({0, 0, -1}, {0, 0, 1}, a, b, c));
  // Just inside: a crossing.
  EXPECT_TRUE(segmentCrossesTriangle({0.5, 1e-6, -1}, {0.5, 1e-6, 1}, a, b, c));
}

TEST(SelfIntersection, CrumpledMeshesAgreeWithBruteForce) {
  int intersecting = 0, compared = 0;
  for (int sample = 0; sample < 60; ++sample) {
    const Mesh mesh = grid(6, 1.0);
    VectorX x = mesh.restPositions;
    // Crumpled: every vertex moved by up to `amount` (from barely to heavily) in every direction.
    const double amount = 0.02 + 0.5 * sample / 60.0;
    for (Eigen::Index i = 0; i < x.size(); ++i) x[i] += uniform(-amount, amount);
    double closest = 1.0;
    const bool expected = bruteForceIntersects(mesh, x, &closest);
    if (closest < 1e-6) continue;
    ++compared;
    intersecting += expected;
    const std::optional<SelfIntersection> found = findSelfIntersection(mesh, x);
    EXPECT_EQ(found.has_value(), expected) << "sample " << sample << ", amount " << amount;
    if (found) {
      // What it names really crosses.
      const Triangle& t = mesh.triangles[found->triangle];
      EXPECT_TRUE(solveCrossing(x.segment<3>(3 * found->edge[0]), x.segment<3>(3 * found->edge[1]),
                                x.segment<3>(3 * t[0]), x.segment<3>(3 * t[1]), x.segment<3>(3 * t[2]))
                      .crosses);
    }
  }
  EXPECT_GT(compared, 50);
  EXPECT_GT(intersecting, 10);
  EXPECT_GT(compared - intersecting, 5);
}

// 129 x 129 vertices (32768 triangles): flat, folded over itself 2 cm above (the fold scene's
// shape), and with one vertex of the top layer pushed through the bottom one.
TEST(SelfIntersection, A129By129ClothFlatFoldedAndPierced) {
  const int n = 129;
  const Mesh mesh = grid(n, 1.0);
  const auto start = std::chrono::steady_clock::now();
  EXPECT_FALSE(findSelfIntersection(mesh, mesh.restPositions).has_value());
  const double flatSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // Rows beyond the middle folded back over the first half, 2 cm above it: y -> 1 - y, and
  // shifted by 0.3 of a cell along x (exactly above the bottom layer's vertices, a vertex pushed
  // through would cross it along its edges: a grazing contact, which the contact distance check
  // catches, not a crossing).
  VectorX folded = mesh.restPositions;
  for (Index i = 0; i < mesh.numVertices(); ++i) {
    if (folded[3 * i + 1] > 0.5) {
      folded[3 * i] += 0.3 / (n - 1);
      folded[3 * i + 1] = 1.0 - folded[3 * i + 1];
      folded[3 * i + 2] = 0.02;
    }
  }
  EXPECT_FALSE(findSelfIntersection(mesh, folded).has_value());
  // Vertex (row 100, col 64) of the top layer, at y = 1 - 100/128, pushed 1 cm below z = 0.
  const Index pushed = 100 * n + 64;
  folded[3 * pushed + 2] = -0.01;
  const std::optional<SelfIntersection> hit = findSelfIntersection(mesh, folded);
  ASSERT_TRUE(hit.has_value());
  EXPECT_TRUE(hit->edge[0] == pushed || hit->edge[1] == pushed) << hit->edge[0] << ", " << hit->edge[1];
  // The crossed triangle is in the bottom layer (its vertices in the first half of the rows).
  for (Index v : mesh.triangles[hit->triangle]) EXPECT_LE(v / n, n / 2);
  std::printf("[ figures  ] flat 129 x 129 cloth checked for self-intersection in %.3f s\n", flatSeconds);
}
