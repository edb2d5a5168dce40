// The mid-edge (Kirchhoff-Love) bending model: derivatives against central differences,
// invariances, the exact plate energy of every quadratic surface on regular, checkerboard,
// irregular and equilateral meshes, the patch test (a constant moment exerts no force), the
// cylinder limit, free and clamped edges, the PSD projection, the element-level API, the
// fold barrier, and the scene's keys and refusals.
//
// Expected values come from the plate formula psi = (D/2)[H11^2 + H22^2 + 2 nu H11 H22 +
// 2 (1 - nu) H12^2] (Timoshenko & Woinowsky-Krieger 1959, sec. 10) written out here, never
// from the model.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <random>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "bending_test_support.h"
#include "test_support.h"
#include "fem_cloth/core/bending_midedge.h"
#include "fem_cloth/core/scene.h"

using namespace fem_cloth;
using namespace fem_cloth::test;

namespace {

/// The plate's energy density (J / m^2) for curvature (H11, H22, H12), written out.
double plateDensity(double D, double nu, const Eigen::Vector3d& H) {
  return 0.5 * D *
         (H[0] * H[0] + H[1] * H[1] + 2.0 * nu * H[0] * H[1] + 2.0 * (1.0 - nu) * H[2] * H[2]);
}

std::unique_ptr<MidedgeBending> midedge(const Cloth& c, double D, double nu,
                                        std::vector<char> held = {}) {
  MidedgeOptions options;
  options.poissonRatio = nu;
  options.held = std::move(held);
  return std::make_unique<MidedgeBending>(*c.mesh, *c.rest, D, options);
}

/// z += eps * (H11 x^2 / 2 + H22 y^2 / 2 + H12 x y), x and y about `centre`.
VectorX quadraticHeight(const VectorX& flat, const Eigen::Vector3d& H, double eps,
                        const Eigen::Vector2d& centre) {
  VectorX x = flat;
  for (Eigen::Index i = 0; i < x.size() / 3; ++i) {
    const double u = flat[3 * i] - centre.x(), v = flat[3 * i + 1] - centre.y();
    x[3 * i + 2] += eps * (0.5 * H[0] * u * u + 0.5 * H[1] * v * v + H[2] * u * v);
  }
  return x;
}

/// A vertex on the boundary of an axis-aligned rectangular sheet [0, w] x [0, h].
bool onRectangleBoundary(const VectorX& rest, Index v, double w, double h) {
  const double x = rest[3 * v], y = rest[3 * v + 1], tol = 1e-9;
  return x < tol || y < tol || x > w - tol || y > h - tol;
}

/// Elements whose triangle lies at least `margin` inside the rectangle [x0, x1] x [y0, y1], so
/// that every hinge its shape operator may read (its own, its neighbours' and theirs) exists:
/// there the model must be exact for quadratic surfaces.
std::vector<Index> elementsInside(const MidedgeBending& term, const Mesh& mesh, double x0, double x1,
                                  double y0, double y1, double margin) {
  std::vector<Index> out;
  for (std::size_t i = 0; i < term.elements().size(); ++i) {
    bool inside = true;
    for (Index v : mesh.triangles[term.elements()[i].triangle]) {
      const double x = mesh.restPositions[3 * v], y = mesh.restPositions[3 * v + 1];
      inside &= x >= x0 + margin && x <= x1 - margin && y >= y0 + margin && y <= y1 - margin;
    }
    if (inside) out.push_back(static_cast<Index>(i));
  }
  return out;
}

/// The same for a w x h sheet of cells about `cell` wide: two and a half cells in.
std::vector<Index> interiorElements(const MidedgeBending& term, const Mesh& mesh, double w, double h, double cell) {
  return elementsInside(term, mesh, 0.0, w, 0.0, h, 2.5 * cell);
}

/// A grid with its interior vertices moved in the plane by up to `jitter` cells.
Mesh jitteredGrid(int n, double side, double jitter, unsigned seed) {
  Mesh mesh = gridMesh(n + 1, n + 1, side, side);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-jitter * side / n, jitter * side / n);
  for (Index v = 0; v < mesh.numVertices(); ++v) {
    if (onRectangleBoundary(mesh.restPositions, v, side, side)) continue;
    mesh.restPositions[3 * v] += u(rng);
    mesh.restPositions[3 * v + 1] += u(rng);
  }
  return mesh;
}

const std::vector<Eigen::Vector3d> kCurvatures = {
    {1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}, {1.0, -1.0, 0.0}, {0.7, 0.4, -0.9}};

/// Max over the interior elements and kCurvatures of |E_e / (A_e psi) - 1| for a small
/// quadratic height field (linear regime: hinge angles ~ 1e-4).
double worstQuadraticError(const Cloth& cloth, double w, double h, double cell, double nu) {
  const double D = 2.0e-3, eps = 1e-3;
  auto term = midedge(cloth, D, nu);
  const std::vector<Index> inner = interiorElements(*term, *cloth.mesh, w, h, cell);
  EXPECT_GT(inner.size(), 10u);
  double worst = 0.0;
  for (const Eigen::Vector3d& H : kCurvatures) {
    const VectorX x = quadraticHeight(cloth.mesh->restPositions, H, eps, {0.5 * w, 0.5 * h});
    for (Index e : inner) {
      double energy = 0.0;
      EXPECT_TRUE(term->evaluateElement(e, x, &energy, nullptr, nullptr));
      const double area = cloth.rest->restArea[term->elements()[e].triangle];
      const double expected = area * plateDensity(D, nu, eps * H);
      worst = std::max(worst, std::abs(energy / expected - 1.0));
    }
  }
  return worst;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Consistency with plate theory
// ---------------------------------------------------------------------------------------------

TEST(MidedgeBending, ExactForEveryQuadraticSurfaceOnTheCheckerboardGrid) {
  // makeGrid alternates its diagonals: half the hinges are mirror images, where the averaged
  // mid-edge normal misses twist; the correction must make every curvature exact.
  for (double nu : {0.0, 0.3}) {
    const Cloth cloth = withRest(gridMesh(11, 11, 1.0, 1.0));
    EXPECT_LT(worstQuadraticError(cloth, 1.0, 1.0, 0.1, nu), 1e-5) << "nu = " << nu;
  }
}

TEST(MidedgeBending, ExactForEveryQuadraticSurfaceOnIrregularAndEquilateralMeshes) {
  const Cloth jittered = withRest(jitteredGrid(10, 1.0, 0.25, 7));
  EXPECT_LT(worstQuadraticError(jittered, 1.0, 1.0, 0.1, 0.3), 1e-5);
  const Mesh lattice = equilateralLattice(11, 11, 0.1);
  // Its rows are staggered by half a spacing: x in [0.05, 1.0] is covered by every row.
  const Cloth cloth = withRest(lattice);
  auto term = midedge(cloth, 1.0, 0.3);
  const double height = 10 * std::sqrt(3.0) / 2 * 0.1;
  const std::vector<Index> inner = elementsInside(*term, lattice, 0.05, 1.0, 0.0, height, 0.25);
  ASSERT_GT(inner.size(), 10u);
  for (const Eigen::Vector3d& H : kCurvatures) {
    const VectorX x = quadraticHeight(lattice.restPositions, H, 1e-3, {0.5, 0.4});
    for (Index e : inner) {
      double energy = 0.0;
      ASSERT_TRUE(term->evaluateElement(e, x, &energy, nullptr, nullptr));
      const double expected = cloth.rest->restArea[term->elements()[e].triangle] *
                              plateDensity(1.0, 0.3, 1e-3 * H);
      EXPECT_NEAR(energy / expected, 1.0, 1e-5) << H.transpose();
    }
  }
}

TEST(MidedgeBending, AConstantMomentExertsNoForceOnInteriorVertices) {
  // The patch test: under a quadratic surface the plate's moment is constant and the exact
  // solution has no transverse load; a consistent but non-telescoping energy (triangle curvatures
  // from each triangle's own three hinges, say) fails it and converges to the wrong plate.
  const Cloth cloth = withRest(jitteredGrid(12, 1.2, 0.2, 3));
  const double D = 1.0, eps = 1e-4;
  auto term = midedge(cloth, D, 0.3);
  const std::vector<Index> inner = interiorElements(*term, *cloth.mesh, 1.2, 1.2, 0.1);
  std::vector<char> innerElement(term->elements().size(), 0);
  for (Index e : inner) innerElement[e] = 1;
  const VertexIncidence byVertex = stencilIncidence(*term, cloth.mesh->numVertices());
  for (const Eigen::Vector3d& H : kCurvatures) {
    const VectorX x = quadraticHeight(cloth.mesh->restPositions, H, eps, {0.6, 0.6});
    const VectorX g = gradientOf(*term, x);
    // Scale: the largest force a single element puts on a vertex.
    double scale = 0.0;
    for (Index e : inner) {
      MidedgeBending::ElementGradient ge;
      double energy = 0.0;
      term->evaluateElement(e, x, &energy, &ge, nullptr);
      scale = std::max(scale, ge.cwiseAbs().maxCoeff());
    }
    ASSERT_GT(scale, 0.0);
    int checked = 0;
    for (Index v = 0; v < cloth.mesh->numVertices(); ++v) {
      bool allInner = byVertex.uses(v).size() > 0;
      for (const VertexIncidence::Use& use : byVertex.uses(v)) allInner &= innerElement[use.element] != 0;
      if (!allInner) continue;
      ++checked;
      // The linear part cancels; what is left is O(eps) smaller (geometric nonlinearity).
      EXPECT_LT(g.segment<3>(3 * v).norm(), 1e-3 * scale) << "vertex " << v << ", H = " << H.transpose();
    }
    EXPECT_GT(checked, 4);
  }
}

TEST(MidedgeBending, RolledGridConvergesToTheCylinderEnergy) {
  // E = (D/2) A / R^2 for the isometric roll. Whole sheet: the two straight edges along the axis
  // are free, so their half-cells relax (O(h)); interior elements: O(h^2) (2 tan(theta/2) for a
  // chord angle theta).
  const double D = 0.8, radius = 0.5;
  double previousAll = 1.0, previousInner = 1.0;
  for (int n : {16, 32, 64}) {
    const Cloth cloth = withRest(gridMesh(n / 2 + 1, n + 1, 1.2, 0.6));
    auto term = midedge(cloth, D, 0.3);
    const VectorX x = rolledIntoCylinder(cloth.mesh->restPositions, radius);
    const double all = energyOf(*term, x) / (0.5 * D * 1.2 * 0.6 / (radius * radius)) - 1.0;
    double inner = 0.0, innerArea = 0.0;
    for (Index e : interiorElements(*term, *cloth.mesh, 1.2, 0.6, 1.2 / n)) {
      double energy = 0.0;
      term->evaluateElement(e, x, &energy, nullptr, nullptr);
      inner += energy;
      innerArea += cloth.rest->restArea[term->elements()[e].triangle];
    }
    const double innerError = inner / (0.5 * D * innerArea / (radius * radius)) - 1.0;
    std::cout << "n = " << std::setw(3) << n << "  whole sheet " << std::setw(12) << all
              << "  interior elements " << std::setw(12) << innerError << "\n";
    EXPECT_LT(std::abs(all), 0.7 * std::abs(previousAll)) << n;
    EXPECT_LT(std::abs(innerError), 0.3 * std::abs(previousInner)) << n;
    previousAll = all;
    previousInner = innerError;
  }
  EXPECT_LT(std::abs(previousAll), 0.02);
  EXPECT_LT(std::abs(previousInner), 1e-3);
}

TEST(MidedgeBending, ClampedTrianglesHoldTheTangent) {
  // A strip held along x <= 0.1 (two vertex columns: the triangles between them are clamp
  // plates) and bent as w = (k/2)(x - 0.1)^2 beyond: C1 at the clamp line, the exact plate
  // energy in every free element away from the free end. Without the clamp rule the first free
  // column pivots on a half-tilted director and reads the wrong curvature.
  const double D = 1.0, nu = 0.3, k = 1.0, eps = 1e-3;
  const Cloth cloth = withRest(gridMesh(5, 9, 0.8, 0.4));
  const VectorX& rest = cloth.mesh->restPositions;
  std::vector<char> held(cloth.mesh->numVertices(), 0);
  VectorX x = rest;
  for (Index v = 0; v < cloth.mesh->numVertices(); ++v) {
    const double u = rest[3 * v] - 0.1;
    if (u <= 1e-9) held[v] = 1;
    if (u > 0.0) x[3 * v + 2] += eps * 0.5 * k * u * u;
  }
  auto clamped = midedge(cloth, D, nu, held);
  auto unclamped = midedge(cloth, D, nu);
  int checked = 0;
  for (std::size_t i = 0; i < clamped->elements().size(); ++i) {
    const MidedgeElement& e = clamped->elements()[i];
    const Triangle& tri = cloth.mesh->triangles[e.triangle];
    bool heldTriangle = true, inside = true;
    for (Index v : tri) {
      heldTriangle &= held[v] != 0;
      inside &= rest[3 * v + 1] > 1e-9 && rest[3 * v + 1] < 0.4 - 1e-9 && rest[3 * v] < 0.6 + 1e-9;
    }
    double energy = 0.0;
    ASSERT_TRUE(clamped->evaluateElement(static_cast<Index>(i), x, &energy, nullptr, nullptr));
    if (heldTriangle) {
      EXPECT_NEAR(energy, 0.0, 1e-20);
    } else if (inside) {
      const double expected = cloth.rest->restArea[e.triangle] * plateDensity(D, nu, {eps * k, 0, 0});
      EXPECT_NEAR(energy / expected, 1.0, 1e-5) << "triangle " << e.triangle;
      ++checked;
    }
  }
  EXPECT_GE(checked, 10);
  // The clamp matters: without it the first free column reads far too little curvature.
  int soft = 0;
  for (std::size_t i = 0; i < unclamped->elements().size(); ++i) {
    const MidedgeElement& e = unclamped->elements()[i];
    double energy = 0.0;
    unclamped->evaluateElement(static_cast<Index>(i), x, &energy, nullptr, nullptr);
    const double expected = cloth.rest->restArea[e.triangle] * plateDensity(D, nu, {eps * k, 0, 0});
    const Triangle& tri = cloth.mesh->triangles[e.triangle];
    const bool free = !(held[tri[0]] && held[tri[1]] && held[tri[2]]);
    if (free && energy < 0.5 * expected) ++soft;
  }
  EXPECT_GT(soft, 0);
}

TEST(MidedgeBending, CurvedRestShapeHasNoEnergyAndUnrollingItCostsTheCylinder) {
  const double D = 1.3, radius = 0.7;
  VectorX flat;
  const Cloth cloth = rolledGridCloth(9, 17, 1.0, 0.5, radius, &flat);
  auto term = midedge(cloth, D, 0.3);
  EXPECT_EQ(energyOf(*term, cloth.mesh->restPositions), 0.0);
  EXPECT_LT(gradientOf(*term, cloth.mesh->restPositions).cwiseAbs().maxCoeff(), 1e-12);
  double inner = 0.0, area = 0.0;
  Mesh flatMesh = *cloth.mesh;
  flatMesh.restPositions = flat;
  for (Index e : interiorElements(*term, flatMesh, 1.0, 0.5, 1.0 / 16)) {
    double energy = 0.0;
    term->evaluateElement(e, flat, &energy, nullptr, nullptr);
    inner += energy;
    area += cloth.rest->restArea[term->elements()[e].triangle];
  }
  EXPECT_NEAR(inner / (0.5 * D * area / (radius * radius)), 1.0, 0.01);
}

// ---------------------------------------------------------------------------------------------
// Derivatives, projection, the element API
// ---------------------------------------------------------------------------------------------

TEST(MidedgeBending, DerivativesMatchCentralDifferencesWithHeldTrianglesAndCurvedRest) {
  Mesh mesh = jitteredGrid(4, 0.8, 0.2, 5);
  mesh.restPositions = wavy(mesh.restPositions, 0.1);
  const Cloth cloth = withRest(mesh);
  std::vector<char> held(mesh.numVertices(), 0);
  for (Index v = 0; v < mesh.numVertices(); ++v) held[v] = v % 5 <= 1;  // the first two columns
  auto term = midedge(cloth, 0.37, 0.3, held);
  SparseHessian H = patternFor(*cloth.mesh, *term);
  const VectorX x = bentState(mesh.restPositions, 13);
  const FiniteDifferenceErrors e = finiteDifferenceErrors(*term, H, x, {1e-2, 1e-3, 1e-4, 1e-5});
  for (std::size_t i = 0; i < e.gradient.size(); ++i) {
    std::cout << "h = 1e-" << i + 2 << "  gradient error " << e.gradient[i] << "  Hessian error "
              << e.hessian[i] << "\n";
  }
  expectConverging(e.gradient, "midedge gradient");
  expectConverging(e.hessian, "midedge Hessian");
}

TEST(MidedgeBending, ProjectedHessianIsPsdExactAtRestAndTheExactOneIsIndefiniteWhenBent) {
  const Cloth cloth = withRest(gridMesh(5, 6, 0.8, 0.6));
  auto term = midedge(cloth, 1.0, 0.3);
  SparseHessian H = patternFor(*cloth.mesh, *term);
  const VectorX x = bentState(cloth.mesh->restPositions, 11);
  const Eigen::MatrixXd exact = hessianOf(*term, H, x, HessianMode::Exact);
  const Eigen::MatrixXd projected = hessianOf(*term, H, x, HessianMode::Projected);
  const double scale = exact.norm();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> exactEig(exact), projectedEig(projected);
  ASSERT_LT(exactEig.eigenvalues().minCoeff(), -1e-4 * scale);
  EXPECT_GT(projectedEig.eigenvalues().minCoeff(), -1e-12 * scale);
  EXPECT_EQ((projected - projected.transpose()).cwiseAbs().maxCoeff(), 0.0);
  // At rest every hinge moment is zero: only the PSD J^T K J remains, in both modes.
  const VectorX& r = cloth.mesh->restPositions;
  EXPECT_LT((hessianOf(*term, H, r, HessianMode::Exact) - hessianOf(*term, H, r, HessianMode::Projected))
                .cwiseAbs()
                .maxCoeff(),
            1e-12 * scale);
}

TEST(MidedgeBending, ElementsSumToTheTerm) {
  Mesh mesh = jitteredGrid(5, 1.0, 0.2, 9);
  const Cloth cloth = withRest(mesh);
  auto term = midedge(cloth, 0.6, 0.2);
  SparseHessian H = patternFor(*cloth.mesh, *term);
  const VectorX x = bentState(mesh.restPositions, 21);
  const Index n = mesh.numVertices();
  double energy = 0.0;
  VectorX g = VectorX::Zero(3 * n);
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (std::size_t i = 0; i < term->elements().size(); ++i) {
    const MidedgeElement& e = term->elements()[i];
    double ee = 0.0;
    MidedgeBending::ElementGradient ge;
    MidedgeBending::ElementHessian he;
    ASSERT_TRUE(term->evaluateElement(static_cast<Index>(i), x, &ee, &ge, &he, HessianMode::Exact));
    energy += ee;
    for (int a = 0; a < e.numVertices; ++a) {
      g.segment<3>(3 * e.vertices[a]) += ge.segment<3>(3 * a);
      for (int b = 0; b < e.numVertices; ++b) {
        K.block<3, 3>(3 * e.vertices[a], 3 * e.vertices[b]) += he.block<3, 3>(3 * a, 3 * b);
      }
    }
    // The element's own projection is PSD.
    ASSERT_TRUE(term->evaluateElement(static_cast<Index>(i), x, &ee, nullptr, &he, HessianMode::Projected));
    const Eigen::SelfAdjointEigenSolver<MidedgeBending::ElementHessian> eig(he);
    EXPECT_GT(eig.eigenvalues().minCoeff(), -1e-10 * (1.0 + he.norm()));
  }
  const double total = energyOf(*term, x);
  EXPECT_NEAR(energy, total, 1e-12 * total);
  const VectorX gt = gradientOf(*term, x);
  EXPECT_LT((g - gt).cwiseAbs().maxCoeff(), 1e-11 * (1 + gt.cwiseAbs().maxCoeff()));
  const Eigen::MatrixXd Kt = hessianOf(*term, H, x, HessianMode::Exact);
  EXPECT_LT((K - Kt).cwiseAbs().maxCoeff(), 1e-10 * (1 + Kt.cwiseAbs().maxCoeff()));
  // Every vertex's stencils are listed.
  const VertexIncidence byVertex = stencilIncidence(*term, n);
  for (Index v = 0; v < n; ++v) EXPECT_GT(byVertex.uses(v).size(), 0u) << v;
}

// ---------------------------------------------------------------------------------------------
// The fold barrier, the measure, the scene
// ---------------------------------------------------------------------------------------------

TEST(MidedgeBending, EnergyGrowsWithoutBoundAsAHingeFoldsFlat) {
  auto hinge = [](double alpha) {
    HingePositions X;
    X.col(0) << 0, 0, 0;
    X.col(1) << 1.3, 0, 0;
    X.col(2) << 0.4, 0.9, 0;
    X.col(3) << 0.7, -0.8 * std::cos(alpha), -0.8 * std::sin(alpha);
    return X;
  };
  const double pi = std::acos(-1.0);
  double previous = 0.0;
  for (double alpha : {0.5, 1.5, 3.0, pi - 1e-3, pi - 1e-5}) {
    double b = 0.0;
    ASSERT_TRUE(midedgeHingeMeasure(hinge(alpha), 0.0, &b));
    EXPECT_NEAR(b, 2.0 * std::tan(alpha / 2), 1e-9 * (1 + std::abs(b)));
    EXPECT_GT(b, previous);
    previous = b;
  }
  EXPECT_GT(previous, 1e5);
  double b = 0.0;
  EXPECT_FALSE(midedgeHingeMeasure(hinge(pi - 1e-8), 0.0, &b));
  EXPECT_EQ(midedgeMeasureOfAngle(0.0), 0.0);
}

TEST(MidedgeBending, SceneKeysDefaultsAndRefusals) {
  Scene s = gridScene(3, 5, 0.4, "backward_euler");
  s.bendingStiffness = 1e-4;
  EXPECT_EQ(s.bendingModel, BendingModel::Midedge);  // the default
  EXPECT_EQ(s.bendingPoissonRatio, 0.0);
  Simulation sim = mustBuild(s);
  ASSERT_EQ(sim.model->numTerms(), 2u);
  EXPECT_EQ(sim.model->term(1).name(), "bending/midedge");
  s.bendingPoissonRatio = 0.5;
  EXPECT_NE(validateScene(s).error().find("bending.poisson_ratio"), std::string::npos);
  s.bendingPoissonRatio = 0.3;
  s.integrator = "xpbd";
  const Status xpbd = validateScene(s);
  ASSERT_FALSE(xpbd.ok());
  EXPECT_NE(xpbd.error().find("bending.model"), std::string::npos) << xpbd.error();
  s.bendingModel = BendingModel::Dihedral;
  EXPECT_TRUE(validateScene(s).ok()) << validateScene(s).error();
  // Projective dynamics needs the quadratic model and says so when the default is in the way.
  s.bendingModel = BendingModel::Midedge;
  s.integrator = "projective_dynamics";
  s.materialModel = "arap";
  const Status pd = validateScene(s);
  ASSERT_FALSE(pd.ok());
  EXPECT_NE(pd.error().find("bending.model: quadratic"), std::string::npos) << pd.error();
}

TEST(MidedgeBending, ScenePinsThatNeverReleaseHoldTheirVertices) {
  Scene s = gridScene(3, 4, 0.3, "backward_euler");
  ScenePin kept, released;
  kept.select.gridEdge = "first_col";
  released.select.gridVertices = {{-1, -1}};
  released.releaseAt = 1.0;
  s.pins = {kept, released};
  const Expected<std::vector<char>> held = heldVertices(s, 16);
  ASSERT_TRUE(held.ok());
  for (Index v = 0; v < 16; ++v) EXPECT_EQ((*held)[v] != 0, v % 4 == 0) << v;
  s.pins[0].select.vertices = {99};
  EXPECT_FALSE(heldVertices(s, 16).ok());
}

TEST(MidedgeBending, BitIdenticalForAnyThreadCountAboveTheParallelThreshold) {
#ifndef _OPENMP
  GTEST_SKIP() << "built without OpenMP";
#else
  // 65 x 65: 8192 elements and 12 160 hinges, above kParallelElementThreshold, so the hinge and
  // element loops run in parallel.
  const Cloth cloth = withRest(gridMesh(65, 65, 1.0, 1.0));
  auto term = midedge(cloth, 1e-3, 0.3);
  SparseHessian H = patternFor(*cloth.mesh, *term);
  const VectorX x = bentState(cloth.mesh->restPositions, 4);
  const int before = omp_get_max_threads();
  std::vector<double> energies;
  std::vector<VectorX> gradients;
  std::vector<std::vector<double>> hessians;
  for (int threads : {1, 2}) {
    omp_set_num_threads(threads);
    energies.push_back(energyOf(*term, x));
    gradients.push_back(gradientOf(*term, x));
    H.setZero();
    EvalRequest request;
    request.energy = false;
    request.hessian = &H;
    term->evaluate(x, request);
    hessians.emplace_back(H.values(), H.values() + H.matrix().nonZeros());
  }
  omp_set_num_threads(before);
  EXPECT_EQ(energies[0], energies[1]);
  EXPECT_TRUE(gradients[0] == gradients[1]);
  EXPECT_TRUE(hessians[0] == hessians[1]);
#endif
}
