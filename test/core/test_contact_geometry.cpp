// Contact geometry: obstacle signed distances, point-triangle and edge-edge distances with their
// derivatives, the IPC barrier and friction functions, additive CCD and the broad phase.
// Values are checked against brute force (dense samples of the surfaces and primitives) and
// closed forms; derivatives against finite differences whose error must fall as the step shrinks.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>
#include <functional>
#include <random>
#include <set>

#include "fem_cloth/core/contact/barrier.h"
#include "fem_cloth/core/contact/broad_phase.h"
#include "fem_cloth/core/contact/ccd.h"
#include "fem_cloth/core/contact/obstacle.h"
#include "fem_cloth/core/contact/primitive_distance.h"
#include "fem_cloth/core/contact/shapes.h"

using namespace fem_cloth;

namespace {

std::mt19937 rng(7);
double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); }
Eigen::Vector3d randomPoint(double r) { return Eigen::Vector3d(uniform(-r, r), uniform(-r, r), uniform(-r, r)); }

// Central-difference errors of an analytic gradient and Hessian for steps eps and eps/10: both
// must be small, and the gradient error must fall (second order: by about 100).
template <int N>
void checkDerivatives(const std::function<double(const Eigen::Matrix<double, N, 1>&)>& f,
                      const std::function<Eigen::Matrix<double, N, 1>(const Eigen::Matrix<double, N, 1>&)>& g,
                      const std::function<Eigen::Matrix<double, N, N>(const Eigen::Matrix<double, N, 1>&)>& H,
                      const Eigen::Matrix<double, N, 1>& x, double eps, const std::string& what) {
  auto errors = [&](double h) {
    Eigen::Matrix<double, N, 1> fdGrad;
    Eigen::Matrix<double, N, N> fdHess;
    for (int i = 0; i < N; ++i) {
      Eigen::Matrix<double, N, 1> xp = x, xm = x;
      xp[i] += h;
      xm[i] -= h;
      fdGrad[i] = (f(xp) - f(xm)) / (2 * h);
      fdHess.col(i) = (g(xp) - g(xm)) / (2 * h);
    }
    const double gScale = std::max(1.0, g(x).norm()), hScale = std::max(1.0, H(x).norm());
    return std::make_pair((fdGrad - g(x)).norm() / gScale, (fdHess - H(x)).norm() / hScale);
  };
  const auto coarse = errors(eps), fine = errors(eps / 10);
  EXPECT_LT(fine.first, 1e-6) << what << ": gradient";
  EXPECT_LT(fine.second, 1e-5) << what << ": Hessian";
  if (coarse.first > 1e-9) {
    EXPECT_LT(fine.first, 0.1 * coarse.first) << what << ": gradient error does not fall";
  }
  if (coarse.second > 1e-9) {
    EXPECT_LT(fine.second, 0.1 * coarse.second) << what << ": Hessian error does not fall";
  }
}

// Dense samples of a shape's surface (independent of signedDistance).
std::vector<Eigen::Vector3d> surfaceSamples(const Shape& s, int n) {
  std::vector<Eigen::Vector3d> out;
  const double pi = std::acos(-1.0);
  auto sphereAround = [&](const Eigen::Vector3d& c, double r, double zMin, double zMax) {
    for (int i = 0; i <= n; ++i) {
      const double theta = pi * i / n;
      for (int j = 0; j < 2 * n; ++j) {
        const double phi = pi * j / n;
        const Eigen::Vector3d p = c + r * Eigen::Vector3d(std::sin(theta) * std::cos(phi),
                                                          std::sin(theta) * std::sin(phi), std::cos(theta));
        if (p.z() >= zMin - 1e-12 && p.z() <= zMax + 1e-12) out.push_back(p);
      }
    }
  };
  switch (s.type) {
    case ShapeType::Plane:
      for (int i = -n; i <= n; ++i) {
        for (int j = -n; j <= n; ++j) out.emplace_back(2.0 * i / n, 2.0 * j / n, 0.0);
      }
      break;
    case ShapeType::Sphere:
      sphereAround(Eigen::Vector3d::Zero(), s.radius, -1e9, 1e9);
      break;
    case ShapeType::Capsule:
      sphereAround(Eigen::Vector3d(0, 0, s.halfLength), s.radius, s.halfLength, 1e9);
      sphereAround(Eigen::Vector3d(0, 0, -s.halfLength), s.radius, -1e9, -s.halfLength);
      for (int i = 0; i <= n; ++i) {
        for (int j = 0; j < 2 * n; ++j) {
          const double phi = pi * j / n, z = -s.halfLength + 2.0 * s.halfLength * i / n;
          out.emplace_back(s.radius * std::cos(phi), s.radius * std::sin(phi), z);
        }
      }
      break;
    case ShapeType::Box:
      for (int axis = 0; axis < 3; ++axis) {
        for (double side : {-1.0, 1.0}) {
          for (int i = 0; i <= n; ++i) {
            for (int j = 0; j <= n; ++j) {
              Eigen::Vector3d p;
              p[axis] = side * s.halfExtents[axis];
              p[(axis + 1) % 3] = s.halfExtents[(axis + 1) % 3] * (2.0 * i / n - 1.0);
              p[(axis + 2) % 3] = s.halfExtents[(axis + 2) % 3] * (2.0 * j / n - 1.0);
              out.push_back(p);
            }
          }
        }
      }
      break;
  }
  return out;
}

std::vector<Shape> testShapes() {
  Shape plane;
  Shape sphere;
  sphere.type = ShapeType::Sphere;
  sphere.radius = 0.3;
  Shape box;
  box.type = ShapeType::Box;
  box.halfExtents = Eigen::Vector3d(0.4, 0.25, 0.1);
  Shape capsule;
  capsule.type = ShapeType::Capsule;
  capsule.radius = 0.15;
  capsule.halfLength = 0.3;
  return {plane, sphere, box, capsule};
}

}  // namespace

TEST(ContactShapes, OutsideDistanceIsTheNearestSurfaceSample) {
  for (const Shape& shape : testShapes()) {
    const std::vector<Eigen::Vector3d> samples = surfaceSamples(shape, 60);
    for (int trial = 0; trial < 40; ++trial) {
      Eigen::Vector3d p = randomPoint(0.8);
      if (shape.type == ShapeType::Plane) p.z() = std::abs(p.z()) + 0.01;
      const SignedDistance sd = signedDistance(shape, p);
      if (sd.distance <= 0.0) continue;
      double nearest = 1e9;
      for (const auto& q : samples) nearest = std::min(nearest, (p - q).norm());
      // Samples are never nearer than the exact distance, and some are nearly as near.
      EXPECT_GE(nearest, sd.distance - 1e-12) << shapeTypeName(shape.type);
      EXPECT_LT(nearest - sd.distance, 0.03) << shapeTypeName(shape.type);
      EXPECT_NEAR((p - sd.closest).norm(), sd.distance, 1e-12);
      EXPECT_NEAR((p - sd.closest).normalized().dot(sd.normal), 1.0, 1e-9);
    }
  }
}

TEST(ContactShapes, InsideDistanceIsMinusTheDepth) {
  Shape sphere = testShapes()[1], box = testShapes()[2], capsule = testShapes()[3];
  EXPECT_NEAR(signedDistance(sphere, Eigen::Vector3d(0.1, 0, 0)).distance, -0.2, 1e-15);
  EXPECT_NEAR(signedDistance(box, Eigen::Vector3d(0.1, 0.2, 0.0)).distance, -0.05, 1e-15);
  EXPECT_NEAR(signedDistance(capsule, Eigen::Vector3d(0.05, 0, 0.2)).distance, -0.1, 1e-15);
  EXPECT_NEAR(signedDistance(capsule, Eigen::Vector3d(0, 0, 0.4)).distance, -0.05, 1e-15);
  EXPECT_EQ(signedDistance(Shape(), Eigen::Vector3d(3, 4, -0.25)).distance, -0.25);
}

TEST(ContactShapes, NormalIsTheGradient) {
  // Central differences of the distance; exact distances have a unit gradient.
  for (const Shape& shape : testShapes()) {
    for (int trial = 0; trial < 40; ++trial) {
      const Eigen::Vector3d p = randomPoint(0.8);
      const SignedDistance sd = signedDistance(shape, p);
      if (sd.distance <= 0.02) continue;
      Eigen::Vector3d fd;
      const double h = 1e-6;
      for (int k = 0; k < 3; ++k) {
        Eigen::Vector3d e = Eigen::Vector3d::Zero();
        e[k] = h;
        fd[k] = (signedDistance(shape, p + e).distance - signedDistance(shape, p - e).distance) / (2 * h);
      }
      EXPECT_LT((fd - sd.normal).norm(), 1e-7) << shapeTypeName(shape.type);
      EXPECT_NEAR(sd.normal.norm(), 1.0, 1e-12);
    }
  }
}

// Every entry of the shape table: named as its type, and its triangulation (what
// fem_cloth_render and the RViz fallback marker draw) lies on the surface its distance describes.
TEST(ContactShapes, TableTriangulationsLieOnTheSurface) {
  ASSERT_EQ(shapeRegistry().size(), testShapes().size());
  for (const Shape& shape : testShapes()) {
    const ShapeEntry& entry = shapeEntry(shape.type);
    EXPECT_EQ(entry.name, shapeTypeName(shape.type));
    const ShapeMesh surface = entry.triangulate(shape, 2.0, 16);
    ASSERT_FALSE(surface.triangles.empty()) << entry.name;
    ASSERT_EQ(surface.normals.size(), surface.positions.size()) << entry.name;
    for (const Eigen::Vector3d& p : surface.positions) {
      EXPECT_NEAR(signedDistance(shape, p).distance, 0.0, 1e-12) << entry.name;
    }
  }
}

TEST(ContactPrimitives, PointTriangleMatchesBruteForce) {
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3d p = randomPoint(1.0), a = randomPoint(1.0), b = randomPoint(1.0), c = randomPoint(1.0);
    const PrimitiveDistance pd = pointTriangleDistance(p, a, b, c);
    double best = 1e9;
    const int n = 300;
    for (int i = 0; i <= n; ++i) {
      for (int j = 0; i + j <= n; ++j) {
        const double u = double(i) / n, v = double(j) / n;
        best = std::min(best, (p - (a + u * (b - a) + v * (c - a))).squaredNorm());
      }
    }
    EXPECT_LE(pd.squared, best + 1e-12);
    EXPECT_NEAR(std::sqrt(pd.squared), std::sqrt(best), 1e-2);
    // r = sum w_k x_k, with weights of a point minus a convex combination.
    EXPECT_NEAR((pd.r - (pd.weights[0] * p + pd.weights[1] * a + pd.weights[2] * b + pd.weights[3] * c)).norm(), 0.0, 1e-12);
    EXPECT_NEAR(pd.weights[0], 1.0, 1e-15);
    EXPECT_NEAR(pd.weights.tail<3>().sum(), -1.0, 1e-12);
    EXPECT_LE(pd.weights.tail<3>().maxCoeff(), 1e-15);
  }
}

TEST(ContactPrimitives, EdgeEdgeMatchesBruteForce) {
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3d a0 = randomPoint(1.0), a1 = randomPoint(1.0), b0 = randomPoint(1.0), b1 = randomPoint(1.0);
    const PrimitiveDistance pd = edgeEdgeDistance(a0, a1, b0, b1);
    double best = 1e9;
    const int n = 400;
    for (int i = 0; i <= n; ++i) {
      for (int j = 0; j <= n; ++j) {
        const double s = double(i) / n, t = double(j) / n;
        best = std::min(best, ((a0 + s * (a1 - a0)) - (b0 + t * (b1 - b0))).squaredNorm());
      }
    }
    EXPECT_LE(pd.squared, best + 1e-12);
    EXPECT_NEAR(std::sqrt(pd.squared), std::sqrt(best), 1e-2);
  }
  // Parallel edges: the distance between the lines where they overlap.
  const PrimitiveDistance parallel = edgeEdgeDistance(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0),
                                                      Eigen::Vector3d(0.5, 0, 0.2), Eigen::Vector3d(1.5, 0, 0.2));
  EXPECT_NEAR(parallel.squared, 0.04, 1e-15);
}

TEST(ContactPrimitives, DerivativesMatchFiniteDifferencesInEveryRegion) {
  using V = Eigen::Matrix<double, 12, 1>;
  using M = Eigen::Matrix<double, 12, 12>;
  auto split = [](const V& x, int k) { return Eigen::Vector3d(x.segment<3>(3 * k)); };
  std::set<int> ptRegions, eeRegions;
  for (int trial = 0; trial < 300; ++trial) {
    V x;
    for (int k = 0; k < 4; ++k) x.segment<3>(3 * k) = randomPoint(1.0);
    auto pt = [&](const V& y, Vector12* g, Matrix12* H) {
      return pointTriangleDistance(split(y, 0), split(y, 1), split(y, 2), split(y, 3), g, H);
    };
    auto ee = [&](const V& y, Vector12* g, Matrix12* H) {
      return edgeEdgeDistance(split(y, 0), split(y, 1), split(y, 2), split(y, 3), g, H);
    };
    for (int which = 0; which < 2; ++which) {
      auto distance = [&](const V& y, Vector12* g, Matrix12* H) { return which == 0 ? pt(y, g, H) : ee(y, g, H); };
      const PrimitiveDistance here = distance(x, nullptr, nullptr);
      // Stay away from region boundaries, where the Hessian jumps: the region must be the same
      // over the whole finite-difference stencil.
      bool stable = true;
      for (int i = 0; i < 12 && stable; ++i) {
        for (double s : {-2e-4, 2e-4}) {
          V y = x;
          y[i] += s;
          const PrimitiveDistance there = distance(y, nullptr, nullptr);
          if (there.freeParameters != here.freeParameters ||
              ((there.weights.array() == 0.0) != (here.weights.array() == 0.0)).any()) {
            stable = false;
          }
        }
      }
      if (!stable) continue;
      (which == 0 ? ptRegions : eeRegions).insert(here.freeParameters);
      checkDerivatives<12>([&](const V& y) { return distance(y, nullptr, nullptr).squared; },
                           [&](const V& y) { Vector12 g; distance(y, &g, nullptr); return V(g); },
                           [&](const V& y) { Vector12 g; Matrix12 H; distance(y, &g, &H); return M(H); },
                           x, 1e-4, which == 0 ? "point-triangle" : "edge-edge");
    }
  }
  // Vertex, edge and face regions were all exercised.
  EXPECT_EQ(ptRegions, (std::set<int>{0, 1, 2}));
  EXPECT_EQ(eeRegions, (std::set<int>{0, 1, 2}));
}

TEST(ContactPrimitives, GaussNewtonBarrierHessianIsPsdAndExactForMotionAlongTheNormal) {
  const double sHat = 0.04;
  for (int trial = 0; trial < 200; ++trial) {
    Eigen::Vector3d x[4];
    for (auto& p : x) p = randomPoint(0.3);
    for (int which = 0; which < 2; ++which) {
      Vector12 g;
      Matrix12 H;
      const PrimitiveDistance pd = which == 0 ? pointTriangleDistance(x[0], x[1], x[2], x[3], &g, &H)
                                              : edgeEdgeDistance(x[0], x[1], x[2], x[3], &g, &H);
      if (pd.squared >= sHat || pd.squared <= 0) continue;
      const double b1 = barrier::first(pd.squared, sHat), b2 = barrier::second(pd.squared, sHat);
      const Matrix12 exact = b2 * g * g.transpose() + b1 * H;
      const Matrix12 gn = barrierGaussNewtonHessian(pd, b1, b2);
      const double scale = gn.norm();
      EXPECT_GE(Eigen::SelfAdjointEigenSolver<Matrix12>(gn).eigenvalues().minCoeff(), -1e-9 * scale);
      // Moving the point (the first edge) along the contact normal, the exact curvature: the
      // distance changes linearly along it.
      Vector12 n = Vector12::Zero();
      for (int k = 0; k < (which == 0 ? 1 : 2); ++k) n.segment<3>(3 * k) = pd.r.normalized();
      EXPECT_NEAR(n.dot(gn * n), n.dot(exact * n), 1e-8 * scale);
    }
  }
}

TEST(ContactPrimitives, EdgeCrossDerivatives) {
  using V = Eigen::Matrix<double, 12, 1>;
  using M = Eigen::Matrix<double, 12, 12>;
  auto split = [](const V& x, int k) { return Eigen::Vector3d(x.segment<3>(3 * k)); };
  for (int trial = 0; trial < 20; ++trial) {
    V x;
    for (int k = 0; k < 4; ++k) x.segment<3>(3 * k) = randomPoint(1.0);
    auto c = [&](const V& y, Vector12* g, Matrix12* H) {
      return edgeCrossSquared(split(y, 0), split(y, 1), split(y, 2), split(y, 3), g, H);
    };
    const Eigen::Vector3d u = split(x, 1) - split(x, 0), v = split(x, 3) - split(x, 2);
    EXPECT_NEAR(c(x, nullptr, nullptr), u.cross(v).squaredNorm(), 1e-12);
    checkDerivatives<12>([&](const V& y) { return c(y, nullptr, nullptr); },
                         [&](const V& y) { Vector12 g; c(y, &g, nullptr); return V(g); },
                         [&](const V& y) { Vector12 g; Matrix12 H; c(y, &g, &H); return M(H); }, x, 1e-4,
                         "edge cross");
  }
}

TEST(ContactBarrier, DerivativesAndLimits) {
  const double sHat = 1e-4;
  for (double s : {1e-8, 1e-6, 2.5e-5, 5e-5, 9.9e-5}) {
    const double h = 1e-4 * s;
    // b' scales with sHat (m^2), b'' is dimensionless.
    EXPECT_NEAR((barrier::value(s + h, sHat) - barrier::value(s - h, sHat)) / (2 * h), barrier::first(s, sHat),
                1e-6 * std::max(std::abs(barrier::first(s, sHat)), sHat));
    EXPECT_NEAR((barrier::first(s + h, sHat) - barrier::first(s - h, sHat)) / (2 * h), barrier::second(s, sHat),
                1e-5 * std::max(std::abs(barrier::second(s, sHat)), 1.0));
    EXPECT_GT(barrier::value(s, sHat), 0.0);
    EXPECT_LT(barrier::first(s, sHat), 0.0);
  }
  // Zero with zero slope and curvature at sHat (C2), infinite at zero distance.
  EXPECT_EQ(barrier::value(sHat, sHat), 0.0);
  EXPECT_NEAR(barrier::first(sHat * (1 - 1e-9), sHat), 0.0, 1e-12);
  EXPECT_NEAR(barrier::second(sHat * (1 - 1e-9), sHat), 0.0, 1e-7);
  EXPECT_TRUE(std::isinf(barrier::value(0.0, sHat)));
  // Closed form b(sHat/4) = -(3/4 sHat)^2 ln(1/4).
  EXPECT_NEAR(barrier::value(0.25 * sHat, sHat), 0.5625 * sHat * sHat * std::log(4.0), 1e-20);
}

TEST(ContactFriction, F0IsTheIntegralOfF1AndCoulombWhenSliding) {
  const double eps = 1e-3;
  for (double y : {0.0, 1e-4, 5e-4, 9.99e-4, 2e-3, 1.0}) {
    const double h = 1e-7;
    if (y > h) {
      EXPECT_NEAR((friction::f0(y + h, eps) - friction::f0(y - h, eps)) / (2 * h), friction::f1(y, eps), 1e-6);
    }
    if (y > 0) {
      EXPECT_NEAR(friction::f1OverY(y, eps), friction::f1(y, eps) / y, 1e-9 / y);
    }
  }
  EXPECT_EQ(friction::f1(2 * eps, eps), 1.0);
  EXPECT_NEAR(friction::f1(eps * (1 - 1e-12), eps), 1.0, 1e-9);  // continuous at eps
  EXPECT_NEAR(friction::f0(eps, eps), eps, 1e-18);
  EXPECT_EQ(friction::f1(0.0, eps), 0.0);
}

TEST(ContactCcd, PointFallingOnATriangleStopsBeforeTheTimeOfImpact) {
  Eigen::Matrix<double, 3, 4> x, dx;
  x << Eigen::Vector3d(0.2, 0.2, 0.5), Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0);
  dx.setZero();
  dx.col(0) = Eigen::Vector3d(0, 0, -1.0);  // reaches the triangle at t = 0.5
  const double t = ccd::pointTriangle(x, dx, 1.0);
  EXPECT_LT(t, 0.5);
  EXPECT_GE(0.5 - t, ccd::kRescaling * 0.5 * 0.5);  // at least s of the distance is kept...
  EXPECT_GT(t, 0.4);                                 // ...and not much more
  // Moving away, or not moving: the whole step.
  EXPECT_EQ(ccd::pointTriangle(x, -dx, 1.0), 1.0);
  EXPECT_EQ(ccd::pointTriangle(x, Eigen::Matrix<double, 3, 4>::Zero(), 1.0), 1.0);
  // The triangle moving up to the point instead (the same relative motion).
  Eigen::Matrix<double, 3, 4> up = Eigen::Matrix<double, 3, 4>::Zero();
  for (int k = 1; k < 4; ++k) up.col(k) = Eigen::Vector3d(0, 0, 1.0);
  EXPECT_LT(ccd::pointTriangle(x, up, 1.0), 0.5);
}

TEST(ContactCcd, CrossingEdgesStopBeforeTheyMeet) {
  Eigen::Matrix<double, 3, 4> x, dx;
  x << Eigen::Vector3d(-1, 0, 0.3), Eigen::Vector3d(1, 0, 0.3), Eigen::Vector3d(0, -1, 0), Eigen::Vector3d(0, 1, 0);
  dx.setZero();
  dx.col(0) = dx.col(1) = Eigen::Vector3d(0, 0, -0.6);  // they meet at t = 0.5
  const double t = ccd::edgeEdge(x, dx, 1.0);
  EXPECT_LT(t, 0.5);
  EXPECT_GT(t, 0.4);
}

TEST(ContactCcd, RandomMotionsNeverReachZeroDistance) {
  int limited = 0;
  for (int trial = 0; trial < 300; ++trial) {
    Eigen::Matrix<double, 3, 4> x, dx;
    for (int k = 0; k < 4; ++k) {
      x.col(k) = randomPoint(0.5);
      dx.col(k) = randomPoint(1.0);
    }
    for (int which = 0; which < 2; ++which) {
      const double t = which == 0 ? ccd::pointTriangle(x, dx, 1.0) : ccd::edgeEdge(x, dx, 1.0);
      if (t < 1.0) ++limited;
      auto dist = [&](double s) {
        const Eigen::Matrix<double, 3, 4> y = x + s * dx;
        return which == 0 ? pointTriangleDistance(y.col(0), y.col(1), y.col(2), y.col(3)).squared
                          : edgeEdgeDistance(y.col(0), y.col(1), y.col(2), y.col(3)).squared;
      };
      const double d0 = std::sqrt(dist(0.0));
      for (int i = 0; i <= 2000; ++i) {
        const double s = t * i / 2000.0;
        ASSERT_GT(std::sqrt(dist(s)), 0.09 * d0) << "trial " << trial << " at t = " << s;
      }
    }
  }
  EXPECT_GT(limited, 10);  // the random motions did include collisions
}

TEST(ContactCcd, SignedDistanceAdvancementAgainstAnObstacle) {
  // A point moving at 1 m/s towards a sphere of radius 0.3 from 1 m: impact at t = 0.7.
  Shape sphere = testShapes()[1];
  const Eigen::Vector3d p(1.0, 0, 0), step(-1.0, 0, 0);
  auto d = [&](double t) { return signedDistance(sphere, p + t * step).distance; };
  const double t = ccd::additive(d, d(0.0), step.norm(), 1.0);
  EXPECT_LT(t, 0.7);
  EXPECT_GT(t, 0.6);
  EXPECT_TRUE(ccd::comesWithin(d, d(0.0), 1.0, 0.05));
  auto away = [&](double t) { return signedDistance(sphere, p - t * step).distance; };
  EXPECT_FALSE(ccd::comesWithin(away, away(0.0), 1.0, 0.05));
}

TEST(ContactBroadPhase, SameAsComparingEveryPair) {
  for (bool same : {false, true}) {
    std::vector<Aabb> a, b;
    for (int i = 0; i < 300; ++i) {
      Aabb box;
      box.extend(randomPoint(1.0));
      box.extend(box.lo + Eigen::Vector3d(uniform(0, 0.1), uniform(0, 0.1), uniform(0, 0.1)));
      (i % 2 ? a : b).push_back(box);
    }
    // One huge box, handled outside the grid.
    Aabb huge;
    huge.extend(Eigen::Vector3d::Constant(-5));
    huge.extend(Eigen::Vector3d::Constant(5));
    a.push_back(huge);
    std::vector<std::pair<int, int>> found;
    auto keep = [](int i, int j) { return (i + j) % 7 != 0; };
    overlappingPairs(a, same ? a : b, same, 0.05, keep, found);
    std::vector<std::pair<int, int>> expected;
    const std::vector<Aabb>& other = same ? a : b;
    for (int i = 0; i < static_cast<int>(a.size()); ++i) {
      for (int j = same ? i + 1 : 0; j < static_cast<int>(other.size()); ++j) {
        if (a[i].overlaps(other[j]) && keep(i, j)) expected.emplace_back(i, j);
      }
    }
    EXPECT_EQ(found, expected);
    EXPECT_GT(expected.size(), 100u);
  }
}

TEST(ContactObstacles, PosesAndScriptedMotion) {
  const Eigen::Matrix3d R = rotationFromRpy(Eigen::Vector3d(0, 0, std::acos(-1.0) / 2));
  EXPECT_TRUE((R * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-15));
  Eigen::Isometry3d a = Eigen::Isometry3d::Identity(), b = Eigen::Isometry3d::Identity();
  b.linear() = R;
  b.translation() = Eigen::Vector3d(1, 2, 3);
  EXPECT_EQ(interpolatePose(a, b, 0.0).matrix(), a.matrix());
  EXPECT_EQ(interpolatePose(a, b, 1.0).matrix(), b.matrix());
  const Eigen::Isometry3d half = interpolatePose(a, b, 0.5);
  EXPECT_TRUE(half.translation().isApprox(Eigen::Vector3d(0.5, 1, 1.5)));
  EXPECT_NEAR(Eigen::AngleAxisd(half.linear()).angle(), std::acos(-1.0) / 4, 1e-12);
  Obstacle o;
  o.velocity = Eigen::Vector3d(0, 0, 0.5);
  EXPECT_TRUE(o.offsetAt(2.0).isApprox(Eigen::Vector3d(0, 0, 1.0)));
  o.velocity.setZero();
  o.trajectory = {{1.0, Eigen::Vector3d(0, 0, 0)}, {2.0, Eigen::Vector3d(1, 0, 0)}};
  EXPECT_EQ(o.offsetAt(0.5), Eigen::Vector3d::Zero());
  EXPECT_TRUE(o.offsetAt(1.25).isApprox(Eigen::Vector3d(0.25, 0, 0)));
  EXPECT_EQ(o.offsetAt(3.0), Eigen::Vector3d(1, 0, 0));
}
