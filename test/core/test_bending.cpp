// The bending terms: hinge topology, the dihedral angle against geometric constructions, the
// assembled gradient and Hessian against central finite differences, invariances, closed-form
// energies of folds and cylinders (the Kirchhoff limit), the factory's errors, and
// thread-count-independent results.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <random>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "bending_test_support.h"
#include "fem_cloth/core/bending.h"

using namespace fem_cloth;
using namespace fem_cloth::test;

#include "../allocation_counter.h"
using fem_cloth::test::allocationCount;

namespace {

const std::vector<std::string> kModels = {"quadratic", "dihedral"};

/// A term with its Hessian pattern built and bound.
struct BoundTerm {
  std::string model;
  std::unique_ptr<EnergyTerm> term;
  SparseHessian hessian;
};

/// The models on the cloth, ready to evaluate.
std::vector<BoundTerm> boundTerms(const Cloth& cloth, double k,
                                  const std::vector<std::string>& models = bendingModelNames()) {
  std::vector<BoundTerm> terms;
  for (const std::string& model : models) {
    auto term = makeTerm(cloth, model, k);
    SparseHessian H = patternFor(*cloth.mesh, *term);
    terms.push_back({model, std::move(term), std::move(H)});
  }
  return terms;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Topology and the angle
// ---------------------------------------------------------------------------------------------

TEST(Hinges, OnePerInteriorEdgeOfAGrid) {
  const int rows = 4, cols = 6;
  const Mesh mesh = gridMesh(rows, cols, 1.0, 0.6);
  const std::vector<Hinge> hinges = buildHinges(mesh);
  // Edges: rows (cols-1) along x, (rows-1) cols along y, (rows-1)(cols-1) diagonals; the
  // 2 (rows-1) + 2 (cols-1) on the boundary carry no hinge.
  const int edges = rows * (cols - 1) + (rows - 1) * cols + (rows - 1) * (cols - 1);
  const int boundary = 2 * (rows - 1) + 2 * (cols - 1);
  EXPECT_EQ(static_cast<int>(hinges.size()), edges - boundary);
  for (const Hinge& h : hinges) {
    const Triangle& A = mesh.triangles[h.triangles[0]];
    const Triangle& B = mesh.triangles[h.triangles[1]];
    // The edge x0 -> x1 runs in A's order, x2 is A's third vertex, x3 is B's.
    bool edgeInOrder = false;
    for (int k = 0; k < 3; ++k) {
      if (A[k] == h.vertices[0] && A[(k + 1) % 3] == h.vertices[1] && A[(k + 2) % 3] == h.vertices[2]) {
        edgeInOrder = true;
      }
    }
    EXPECT_TRUE(edgeInOrder);
    int shared = 0;
    for (Index v : B) {
      shared += (v == h.vertices[0] || v == h.vertices[1]) ? 1 : 0;
      EXPECT_TRUE(v == h.vertices[0] || v == h.vertices[1] || v == h.vertices[3]);
    }
    EXPECT_EQ(shared, 2);
  }
}

TEST(Hinges, BoundaryAndNonManifoldEdgesCarryNone) {
  Mesh mesh;
  mesh.restPositions = VectorX::Zero(15);
  mesh.triangles = {{0, 1, 2}, {1, 0, 3}};
  ASSERT_EQ(buildHinges(mesh).size(), 1u);
  EXPECT_EQ(buildHinges(mesh)[0].vertices, (std::array<Index, 4>{0, 1, 2, 3}));
  // A third triangle on edge 0-1 makes it non-manifold: no pair to bend between.
  mesh.triangles.push_back({0, 1, 4});
  EXPECT_TRUE(buildHinges(mesh).empty());
}

TEST(DihedralAngle, MatchesTheFoldOfAConstructedHinge) {
  // Edge along x; x2 in the half plane y > 0 of z = 0 (so n1 = +z); x3 at distance 0.8 from the
  // axis, turned by alpha from the unfolded position (y < 0, z = 0) towards -z: theta = alpha.
  HingePositions X;
  for (double alpha : {0.0, 0.3, 1.2, 2.5, -0.7, -2.9, std::acos(-1.0) - 1e-9}) {
    X.col(0) << 0, 0, 0;
    X.col(1) << 1.3, 0, 0;
    X.col(2) << 0.4, 0.9, 0;
    X.col(3) << 0.7, -0.8 * std::cos(alpha), -0.8 * std::sin(alpha);
    double theta = 99.0;
    ASSERT_TRUE(dihedralAngle(X, &theta));
    EXPECT_NEAR(theta, alpha, 1e-14) << alpha;
    // The same hinge, rotated and moved, has the same angle.
    const Eigen::Matrix3d R = someRotation();
    HingePositions Y = R * X;
    Y.colwise() += Eigen::Vector3d(0.3, -1, 2);
    ASSERT_TRUE(dihedralAngle(Y, &theta));
    EXPECT_NEAR(theta, alpha, 1e-13) << alpha;
  }
}

TEST(DihedralAngle, DegenerateHingeIsReported) {
  HingePositions X;
  X << 0, 1, 0.5, 0.5,  //
      0, 0, 0, -1,       // x2 on the edge line: triangle (x0, x1, x2) has no area
      0, 0, 0, 0;
  double theta = 7.0;
  HingeVector g = HingeVector::Constant(3.0);
  EXPECT_FALSE(dihedralAngle(X, &theta, &g));
  EXPECT_EQ(theta, 7.0);
  EXPECT_EQ(g[0], 3.0);
}

TEST(Stiffness, PlateFormula) {
  // E = 1 MPa, h = 1 mm, nu = 0.3: k = 1e6 * 1e-9 / (12 * 0.91) N m.
  EXPECT_NEAR(bendingStiffness(1e6, 1e-3, 0.3), 1e-3 / 10.92, 1e-18);
  // Cubic in the thickness.
  EXPECT_NEAR(bendingStiffness(2e9, 2e-4, 0.0) / bendingStiffness(2e9, 1e-4, 0.0), 8.0, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Derivatives
// ---------------------------------------------------------------------------------------------

class BendingDerivatives : public testing::TestWithParam<std::tuple<std::string, bool>> {};

TEST_P(BendingDerivatives, MatchCentralDifferences) {
  const auto [model, curvedRest] = GetParam();
  Mesh mesh = gridMesh(4, 5, 0.8, 0.6);
  if (curvedRest) mesh.restPositions = wavy(mesh.restPositions, 0.1);
  const Cloth cloth = withRest(mesh);
  auto term = makeTerm(cloth, model, 0.37);
  SparseHessian H = patternFor(*cloth.mesh, *term);
  const VectorX x = bentState(mesh.restPositions, 11);
  const FiniteDifferenceErrors e = finiteDifferenceErrors(*term, H, x, {1e-2, 1e-3, 1e-4, 1e-5});
  for (std::size_t i = 0; i < e.gradient.size(); ++i) {
    std::cout << model << (curvedRest ? " curved rest" : " flat rest") << ": h = 1e-" << i + 2
              << "  gradient error " << e.gradient[i] << "  Hessian error " << e.hessian[i] << "\n";
  }
  if (model == "quadratic") {
    // Quadratic energy: central differences are exact up to round-off for every h.
    EXPECT_LT(*std::max_element(e.gradient.begin(), e.gradient.end()), 1e-9);
    EXPECT_LT(*std::max_element(e.hessian.begin(), e.hessian.end()), 1e-9);
  } else {
    expectConverging(e.gradient, model + " gradient");
    expectConverging(e.hessian, model + " Hessian");
  }
  const Eigen::MatrixXd K = hessianOf(*term, H, x, HessianMode::Exact);
  EXPECT_EQ((K - K.transpose()).cwiseAbs().maxCoeff(), 0.0);
}

INSTANTIATE_TEST_SUITE_P(Models, BendingDerivatives,
                         testing::Combine(testing::ValuesIn(bendingModelNames()), testing::Bool()));

TEST(DihedralBending, ProjectedHessianIsPsdWhereTheExactOneIsNot) {
  const Cloth cloth = withRest(gridMesh(4, 5, 0.8, 0.6));
  auto term = makeTerm(cloth, "dihedral", 1.0);
  SparseHessian H = patternFor(*cloth.mesh, *term);
  const VectorX x = bentState(cloth.mesh->restPositions, 11);
  const Eigen::MatrixXd exact = hessianOf(*term, H, x, HessianMode::Exact);
  const Eigen::MatrixXd projected = hessianOf(*term, H, x, HessianMode::Projected);
  const double scale = exact.norm();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> exactEig(exact), projectedEig(projected);
  // Otherwise the check below would prove nothing.
  ASSERT_LT(exactEig.eigenvalues().minCoeff(), -1e-3 * scale);
  EXPECT_GT(projectedEig.eigenvalues().minCoeff(), -1e-12 * scale);
  EXPECT_EQ((projected - projected.transpose()).cwiseAbs().maxCoeff(), 0.0);
}

TEST(QuadraticBending, HessianIsConstantExactAndPsd) {
  const Cloth cloth = withRest(gridMesh(4, 5, 0.8, 0.6));
  auto term = makeTerm(cloth, "quadratic", 2.0);
  EXPECT_TRUE(term->hasConstantHessian());
  SparseHessian H = patternFor(*cloth.mesh, *term);
  const VectorX x1 = randomlyPerturbed(cloth.mesh->restPositions, 0.1, 3);
  const VectorX x2 = randomlyPerturbed(wavy(cloth.mesh->restPositions, 0.3), 0.1, 4);
  const Eigen::MatrixXd K1 = hessianOf(*term, H, x1, HessianMode::Exact);
  EXPECT_EQ((hessianOf(*term, H, x2, HessianMode::Exact) - K1).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((hessianOf(*term, H, x1, HessianMode::Projected) - K1).cwiseAbs().maxCoeff(), 0.0);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(K1);
  EXPECT_GT(eig.eigenvalues().minCoeff(), -1e-12 * K1.norm());
  // A quadratic form without linear or constant part: E(x) = x^T K x / 2.
  EXPECT_NEAR(energyOf(*term, x2), 0.5 * x2.dot(K1 * x2), 1e-12 * (1 + energyOf(*term, x2)));
}

TEST(Bending, StencilsAreTheHinges) {
  // The Hessian pattern couples exactly the four vertices of each hinge.
  const Cloth cloth = withRest(gridMesh(3, 3, 1.0, 1.0));
  auto term = makeTerm(cloth, "dihedral", 1.0);
  std::vector<std::vector<Index>> stencils;
  term->appendStencils(&stencils);
  const std::vector<Hinge> hinges = buildHinges(*cloth.mesh);
  ASSERT_EQ(stencils.size(), hinges.size());
  for (std::size_t h = 0; h < hinges.size(); ++h) {
    EXPECT_EQ(stencils[h], std::vector<Index>(hinges[h].vertices.begin(), hinges[h].vertices.end()));
  }
}

// ---------------------------------------------------------------------------------------------
// Rest, invariances
// ---------------------------------------------------------------------------------------------

TEST(Bending, ZeroEnergyAndGradientAtRest) {
  for (const std::string& model : bendingModelNames()) {
    const Cloth cloth = withRest(gridMesh(5, 6, 1.0, 0.8));
    auto term = makeTerm(cloth, model, 3.0);
    const VectorX& x = cloth.mesh->restPositions;
    // Zero up to round-off: for the quadratic model sum_a K_a x_a cancels only to ~1e-16 |x|.
    EXPECT_NEAR(energyOf(*term, x), 0.0, 1e-24) << model;
    EXPECT_LT(gradientOf(*term, x).cwiseAbs().maxCoeff(), 1e-12) << model;
  }
}

TEST(Bending, InvariantUnderRigidMotion) {
  const Eigen::Matrix3d R = someRotation();
  const Eigen::Vector3d t(0.1, -2.0, 5.0);
  for (const std::string& model : bendingModelNames()) {
    const Cloth cloth = withRest(gridMesh(5, 6, 1.0, 0.8));
    auto term = makeTerm(cloth, model, 3.0);
    const VectorX x = bentState(cloth.mesh->restPositions, 5);
    const VectorX y = rigidlyMoved(x, R, t);
    const double e = energyOf(*term, x);
    ASSERT_GT(e, 1e-3) << model;
    EXPECT_NEAR(energyOf(*term, y), e, 1e-12 * e) << model;
    // The gradient turns with the body: g(R x + t) = R g(x).
    const VectorX gy = gradientOf(*term, y);
    const VectorX gx = rigidlyMoved(gradientOf(*term, x), R, Eigen::Vector3d::Zero());
    EXPECT_LT((gy - gx).cwiseAbs().maxCoeff(), 1e-11 * (1 + gx.cwiseAbs().maxCoeff())) << model;
    // The rest shape moved rigidly costs nothing.
    EXPECT_NEAR(energyOf(*term, rigidlyMoved(cloth.mesh->restPositions, R, t)), 0.0, 1e-12) << model;
  }
}

TEST(QuadraticBending, AffineMapsOfAFlatRestMeshCostNothing) {
  // An irregular flat rest mesh: a grid jiggled in its plane, so the cotangent weights differ
  // from hinge to hinge.
  Mesh mesh = gridMesh(5, 6, 1.0, 0.8);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-0.04, 0.04);
  for (Index i = 0; i < mesh.numVertices(); ++i) {
    mesh.restPositions[3 * i] += u(rng);
    mesh.restPositions[3 * i + 1] += u(rng);
  }
  const Cloth cloth = withRest(mesh);
  auto term = makeTerm(cloth, "quadratic", 5.0);
  Eigen::Matrix3d general;
  general << 1.3, -0.4, 0.2, 0.5, 0.9, -1.1, 0.3, 0.7, 2.0;
  Eigen::Matrix3d flattening;  // rank 2: maps the sheet into the plane x + y + z = 0
  flattening << 1, 0, 0, 0, 1, 0, -1, -1, 0;
  for (const Eigen::Matrix3d& A : {general, flattening, Eigen::Matrix3d(3.0 * someRotation())}) {
    const VectorX x = rigidlyMoved(cloth.mesh->restPositions, A, Eigen::Vector3d(1, 2, 3));
    // Round-off of sum_a K_a x_a with |x| up to ~6 m, times weights k / (A1 + A2) ~ 200 N/m.
    EXPECT_NEAR(energyOf(*term, x), 0.0, 1e-20);
    EXPECT_LT(gradientOf(*term, x).cwiseAbs().maxCoeff(), 1e-10);
  }
  // Bending the same mesh does cost energy.
  EXPECT_GT(energyOf(*term, wavy(cloth.mesh->restPositions, 0.1)), 1e-3);
}

// ---------------------------------------------------------------------------------------------
// Closed-form energies
// ---------------------------------------------------------------------------------------------

TEST(Bending, FoldAlongAGridLineMatchesClosedFormEitherWay) {
  // Fold a flat rows x cols grid (spacing a across, b along the fold) along the vertex column
  // u = u0 by +-alpha: rows - 1 hinges bend by alpha, each of weight k b^2 / (2 * a b), so
  // E = k (rows - 1) b alpha^2 / (2 a). The diagonals next to the fold stay flat.
  const int rows = 4, cols = 5;
  const double width = 1.0, height = 0.6, k = 2.5;
  const double a = width / (cols - 1), b = height / (rows - 1);
  const Cloth cloth = withRest(gridMesh(rows, cols, width, height));
  auto dihedral = makeTerm(cloth, "dihedral", k);
  auto quadratic = makeTerm(cloth, "quadratic", k);
  const double u0 = 2 * a;
  for (double alpha : {0.4, 1.5}) {
    double energies[2][2];
    for (int side = 0; side < 2; ++side) {
      const double turn = side == 0 ? alpha : -alpha;
      VectorX x = cloth.mesh->restPositions;
      for (Index i = 0; i < cloth.mesh->numVertices(); ++i) {
        const double d = x[3 * i] - u0;
        if (d <= 0) continue;
        x[3 * i] = u0 + d * std::cos(turn);
        x[3 * i + 2] = d * std::sin(turn);
      }
      energies[0][side] = energyOf(*dihedral, x);
      energies[1][side] = energyOf(*quadratic, x);
    }
    const double expected = k * (rows - 1) * b * alpha * alpha / (2 * a);
    EXPECT_NEAR(energies[0][0], expected, 1e-12 * expected) << alpha;
    EXPECT_NEAR(energies[0][1], expected, 1e-12 * expected) << alpha;
    // Quadratic: the same hinges, with |K x| = (b/a) |2 x0 - x2 - x3| = 2 b sin(alpha/2) in
    // place of |e| alpha = b alpha; up and down are mirror images.
    const double s = std::sin(alpha / 2) / (alpha / 2);
    EXPECT_NEAR(energies[1][0], expected * s * s, 1e-12 * expected) << alpha;
    EXPECT_NEAR(energies[1][1], expected * s * s, 1e-12 * expected) << alpha;
  }
}

TEST(DihedralBending, FoldingThroughPiIsContinuous) {
  // One hinge folded at rest by 3.0 rad (x3 turned as in the angle test). Folding it on to
  // 3.3 rad makes the measured angle jump to 3.3 - 2 pi; the energy still sees a turn of 0.3.
  auto hingeMesh = [](double alpha) {
    Mesh mesh;
    mesh.restPositions.resize(12);
    mesh.restPositions << 0, 0, 0, 1, 0, 0, 0.4, 0.9, 0, 0.7, -0.8 * std::cos(alpha),
        -0.8 * std::sin(alpha);
    mesh.triangles = {{0, 1, 2}, {1, 0, 3}};
    return mesh;
  };
  const double k = 1.7;
  const Cloth cloth = withRest(hingeMesh(3.0));
  auto term = makeTerm(cloth, "dihedral", k);
  // |e| = 1, rest areas 0.45 and 0.4: weight k / (2 * 0.85).
  const double expected = k / (2 * 0.85) * 0.3 * 0.3;
  EXPECT_NEAR(energyOf(*term, hingeMesh(3.3).restPositions), expected, 1e-12 * expected);
  EXPECT_NEAR(energyOf(*term, hingeMesh(2.7).restPositions), expected, 1e-12 * expected);
}

TEST(DihedralBending, KeepsACurvedRestShape) {
  const double radius = 0.7, k = 1.3;
  VectorX flat;
  const Cloth cloth = rolledGridCloth(6, 9, 1.0, 0.5, radius, &flat);
  const VectorX& rest = cloth.mesh->restPositions;
  auto dihedral = makeTerm(cloth, "dihedral", k);
  EXPECT_EQ(energyOf(*dihedral, rest), 0.0);
  EXPECT_LT(gradientOf(*dihedral, rest).cwiseAbs().maxCoeff(), 1e-12);
  // Unrolling it costs what rolling the flat sheet costs: every axial hinge turns by a / R.
  const double a = 1.0 / 8, b = 0.5 / 5;
  const double chord = 2 * radius * std::sin(a / (2 * radius));  // rest spacing across
  const double perHinge = k * b * b / (2 * chord * b) * (a / radius) * (a / radius);
  EXPECT_NEAR(energyOf(*dihedral, flat), 7 * 5 * perHinge, 1e-12 * perHinge);
  // The quadratic model measures bending away from flat: the curved rest shape has energy and
  // the flat sheet has (almost, the rest cotangents are those of the curved hinges) none.
  auto quadratic = makeTerm(cloth, "quadratic", k);
  const double cylinder = 0.5 * k * 1.0 * 0.5 / (radius * radius);
  EXPECT_GT(energyOf(*quadratic, rest), 0.5 * cylinder);
  EXPECT_LT(energyOf(*quadratic, flat), 0.01 * cylinder);
}

namespace {

struct ConvergenceRow {
  int cols;
  double error[2];  // relative error of quadratic, dihedral
};

/// Relative errors (E - Ekirchhoff) / Ekirchhoff of both models for a sheet rolled into a
/// cylinder of radius R: Ekirchhoff = (k/2) A / R^2.
std::vector<ConvergenceRow> cylinderErrors(const std::string& meshName, double radius,
                                           const std::vector<int>& resolutions) {
  const double k = 0.8;
  std::vector<ConvergenceRow> rows;
  for (int n : resolutions) {
    Mesh mesh;
    double area = 0.0;
    if (meshName == "grid") {
      // 1.2 m around the circumference, 0.6 m along the axis.
      mesh = gridMesh(n / 2 + 1, n + 1, 1.2, 0.6);
      area = 1.2 * 0.6;
    } else {
      const double spacing = 1.2 / n;
      const int latticeRows = static_cast<int>(std::lround(0.6 / (std::sqrt(3.0) / 2 * spacing))) + 1;
      mesh = equilateralLattice(latticeRows, n + 1, spacing);
      area = (latticeRows - 1) * n * spacing * (std::sqrt(3.0) / 2 * spacing);
    }
    const Cloth cloth = withRest(mesh);
    const VectorX x = rolledIntoCylinder(mesh.restPositions, radius);
    const double expected = 0.5 * k * area / (radius * radius);
    ConvergenceRow row{n, {0, 0}};
    for (int m = 0; m < 2; ++m) {
      row.error[m] = (energyOf(*makeTerm(cloth, kModels[m], k), x) - expected) / expected;
    }
    rows.push_back(row);
    std::cout << std::setw(8) << meshName << "  R = " << radius << "  n = " << std::setw(3) << n
              << "  quadratic " << std::setw(12) << row.error[0] << "  dihedral " << std::setw(12)
              << row.error[1] << "\n";
  }
  return rows;
}

}  // namespace

TEST(Bending, RolledGridConvergesToKirchhoffCylinder) {
  for (double radius : {0.5, 1.0}) {
    const std::vector<ConvergenceRow> rows = cylinderErrors("grid", radius, {4, 8, 16, 32, 64});
    for (const ConvergenceRow& r : rows) {
      // Dihedral: every interior hinge along the axis turns by exactly a / R (a = 1.2 / n) and
      // carries (k/2) a b / R^2; the half cells along the two straight edges have no hinge, so
      // E = (k/2) (A / R^2) (n - 1) / n: the relative error is -1/n, exactly.
      EXPECT_NEAR(r.error[1], -1.0 / r.cols, 1e-12) << "n = " << r.cols;
      // Quadratic: only the same hinges bend (the others see an affine map of their flat rest
      // hinge, which K annihilates), with |K x| = (b/a) |2 p(u) - p(u - a) - p(u + a)| =
      // (b/a) 4 R sin^2(phi/2), phi = a / R, against a b / R for the continuum: each carries
      // the continuum's share times s^4, s = sin(phi/2) / (phi/2).
      const double halfTurn = 0.6 / (r.cols * radius);
      const double s = std::sin(halfTurn) / halfTurn;
      EXPECT_NEAR(r.error[0], (1.0 - 1.0 / r.cols) * std::pow(s, 4) - 1.0, 1e-12) << "n = " << r.cols;
    }
    for (std::size_t i = 1; i < rows.size(); ++i) {
      for (int m = 0; m < 2; ++m) EXPECT_LT(std::abs(rows[i].error[m]), 0.6 * std::abs(rows[i - 1].error[m]));
    }
    EXPECT_LT(std::abs(rows.back().error[0]), 0.02);
    EXPECT_LT(std::abs(rows.back().error[1]), 0.02);
  }
}

TEST(Bending, RolledEquilateralLatticeConvergesToKirchhoffCylinder) {
  // Here every edge direction bends (the axis is at 90 and +-30 degrees to the edges), so this
  // checks the calibration of both models beyond the axis-aligned grid.
  for (double radius : {0.5, 1.0}) {
    const std::vector<ConvergenceRow> rows = cylinderErrors("lattice", radius, {4, 8, 16, 32, 64});
    for (std::size_t i = 1; i < rows.size(); ++i) {
      for (int m = 0; m < 2; ++m) EXPECT_LT(std::abs(rows[i].error[m]), 0.7 * std::abs(rows[i - 1].error[m]));
    }
    EXPECT_LT(std::abs(rows.back().error[0]), 0.03);
    EXPECT_LT(std::abs(rows.back().error[1]), 0.03);
  }
}

// ---------------------------------------------------------------------------------------------
// Domain, factory, threads, allocations
// ---------------------------------------------------------------------------------------------

TEST(DihedralBending, CollapsedTriangleIsOutOfDomain) {
  const Cloth cloth = withRest(gridMesh(3, 3, 1.0, 1.0));
  auto term = makeTerm(cloth, "dihedral", 1.0);
  const std::vector<Hinge> hinges = buildHinges(*cloth.mesh);
  // Put vertex x2 of hinge 1 onto the midpoint of its edge: its triangle has no normal.
  const Hinge& h = hinges[1];
  VectorX x = cloth.mesh->restPositions;
  x.segment<3>(3 * h.vertices[2]) =
      0.5 * (x.segment<3>(3 * h.vertices[0]) + x.segment<3>(3 * h.vertices[1]));
  // Expected: the first hinge with a zero-area triangle at x (this collapses triangle A of
  // hinge 1 and possibly others whose vertices lie on the same grid line).
  Index firstDegenerate = -1;
  for (std::size_t i = 0; i < hinges.size() && firstDegenerate < 0; ++i) {
    for (Index t : hinges[i].triangles) {
      const Triangle& tri = cloth.mesh->triangles[t];
      const Eigen::Vector3d p0 = x.segment<3>(3 * tri[0]);
      const double area =
          (x.segment<3>(3 * tri[1]) - p0).cross(x.segment<3>(3 * tri[2]) - p0).norm();
      if (area == 0.0 && firstDegenerate < 0) firstDegenerate = static_cast<Index>(i);
    }
  }
  ASSERT_GE(firstDegenerate, 0);
  const EvalResult r = term->evaluate(x, EvalRequest{});
  EXPECT_FALSE(r.inDomain);
  EXPECT_EQ(r.energy, kInfiniteEnergy);
  EXPECT_EQ(r.firstBadElement, firstDegenerate);
}

TEST(BendingFactory, ValidatesItsInputs) {
  const Cloth cloth = withRest(gridMesh(3, 3, 1.0, 1.0));
  for (const std::string& model : bendingModelNames()) {
    auto none = makeBendingTerm(*cloth.mesh, *cloth.rest, model, 0.0);
    ASSERT_TRUE(none.ok());
    EXPECT_EQ(none.value(), nullptr) << "zero stiffness: not assembled at all";
    auto term = makeBendingTerm(*cloth.mesh, *cloth.rest, model, 1e-4);
    ASSERT_TRUE(term.ok());
    EXPECT_EQ(term.value()->name(), "bending/" + model);
  }
  auto negative = makeBendingTerm(*cloth.mesh, *cloth.rest, "dihedral", -1.5);
  ASSERT_FALSE(negative.ok());
  EXPECT_NE(negative.error().find("-1.5"), std::string::npos) << negative.error();
  auto notANumber = makeBendingTerm(*cloth.mesh, *cloth.rest, "quadratic", std::nan(""));
  ASSERT_FALSE(notANumber.ok());
  EXPECT_NE(notANumber.error().find("nan"), std::string::npos) << notANumber.error();
  auto infinite = makeBendingTerm(*cloth.mesh, *cloth.rest, "quadratic", std::numeric_limits<double>::infinity());
  EXPECT_FALSE(infinite.ok());
  auto unknown = makeBendingTerm(*cloth.mesh, *cloth.rest, "kirchhoff", 1.0);
  ASSERT_FALSE(unknown.ok());
  for (const char* word : {"kirchhoff", "midedge", "quadratic", "dihedral"}) {
    EXPECT_NE(unknown.error().find(word), std::string::npos) << unknown.error();
  }
  GridSpec planarSpec;
  planarSpec.dim = 2;
  const Mesh planar = *makeGrid(planarSpec);
  auto flat = makeBendingTerm(planar, *computeRestState(planar), "dihedral", 1.0);
  ASSERT_FALSE(flat.ok());
  EXPECT_NE(flat.error().find("planar"), std::string::npos) << flat.error();
  const Cloth other = withRest(gridMesh(4, 4, 1.0, 1.0));
  EXPECT_FALSE(makeBendingTerm(*cloth.mesh, *other.rest, "dihedral", 1.0).ok());
}

TEST(Bending, BitIdenticalForAnyThreadCount) {
#ifndef _OPENMP
  GTEST_SKIP() << "built without OpenMP";
#else
  const Cloth cloth = withRest(gridMesh(21, 23, 1.0, 0.9));
  const VectorX x = bentState(cloth.mesh->restPositions, 2);
  const int before = omp_get_max_threads();
  for (BoundTerm& t : boundTerms(cloth, 0.9)) {
    std::vector<double> energies;
    std::vector<VectorX> gradients;
    std::vector<Eigen::MatrixXd> hessians;
    for (int threads : {1, 2, 3, 4}) {
      omp_set_num_threads(threads);
      energies.push_back(energyOf(*t.term, x));
      gradients.push_back(gradientOf(*t.term, x));
      hessians.push_back(hessianOf(*t.term, t.hessian, x, HessianMode::Projected));
    }
    for (std::size_t i = 1; i < energies.size(); ++i) {
      EXPECT_EQ(energies[i], energies[0]) << t.model;
      EXPECT_TRUE(gradients[i] == gradients[0]) << t.model;
      EXPECT_TRUE(hessians[i] == hessians[0]) << t.model;
    }
  }
  omp_set_num_threads(before);
#endif
}

TEST(Bending, SteadyStateEvaluationAllocatesNothing) {
#ifndef FEM_CLOTH_COUNT_ALLOCATIONS
  GTEST_SKIP() << "allocation counting needs glibc";
#else
  const Cloth cloth = withRest(gridMesh(8, 9, 1.0, 0.9));
  const VectorX x = bentState(cloth.mesh->restPositions, 2);
  for (BoundTerm& t : boundTerms(cloth, 0.9)) {
    VectorX g = VectorX::Zero(x.size());
    EvalRequest request;
    request.gradient = &g;
    request.hessian = &t.hessian;
    t.term->evaluate(x, request);  // warm-up (thread pool start-up may allocate)
    const long before = allocationCount.load();
    for (HessianMode mode : {HessianMode::Exact, HessianMode::Projected}) {
      request.hessianMode = mode;
      t.term->evaluate(x, request);
    }
    EXPECT_EQ(allocationCount.load() - before, 0) << t.model;
  }
  // The counter does see allocations (the volatile pointer keeps the pair from being elided).
  const long check = allocationCount.load();
  void* volatile probe = std::malloc(64);
  std::free(probe);
  EXPECT_EQ(allocationCount.load() - check, 1);
#endif
}
