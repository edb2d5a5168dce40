// Mesh builders and validation. Expected values come from hand counts and closed forms.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>

#include "fem_cloth/core/mesh.h"
#include "fem_cloth/core/rest_state.h"

using namespace fem_cloth;

namespace {

bool anyContains(const std::vector<std::string>& messages, const std::string& needle) {
  for (const auto& m : messages) {
    if (m.find(needle) != std::string::npos) return true;
  }
  return false;
}

}  // namespace

TEST(Grid, CountsAndExtent) {
  GridSpec spec;
  spec.rows = 4;
  spec.cols = 5;
  spec.width = 2.0;
  spec.height = 1.5;
  const Expected<Mesh> mesh = makeGrid(spec);
  ASSERT_TRUE(mesh.ok()) << mesh.error();
  EXPECT_EQ(mesh->numVertices(), 20);
  EXPECT_EQ(mesh->numTriangles(), 2 * 3 * 4);
  // Edges of a rows x cols grid with one diagonal per quad: horizontal + vertical + diagonal.
  EXPECT_EQ(uniqueEdges(mesh->triangles).size(), static_cast<std::size_t>(4 * 4 + 3 * 5 + 3 * 4));
  // Vertex (r, c) = r*cols + c sits at (c*dx, r*dy, 0).
  EXPECT_DOUBLE_EQ(mesh->restPositions[3 * 19 + 0], 2.0);
  EXPECT_DOUBLE_EQ(mesh->restPositions[3 * 19 + 1], 1.5);
  EXPECT_DOUBLE_EQ(mesh->restPositions[3 * 7 + 0], 1.0);
  EXPECT_DOUBLE_EQ(mesh->restPositions[3 * 7 + 1], 0.5);
  EXPECT_TRUE(validateMesh(*mesh).ok());
  EXPECT_TRUE(validateMesh(*mesh).warnings.empty());
}

TEST(Grid, TotalAreaAndMass) {
  GridSpec spec;
  spec.rows = 9;
  spec.cols = 7;
  spec.width = 1.2;
  spec.height = 0.8;
  const Mesh mesh = *makeGrid(spec);
  const RestState rest = *computeRestState(mesh);
  double area = 0.0;
  for (double a : rest.restArea) area += a;
  EXPECT_NEAR(area, 1.2 * 0.8, 1e-12);
  const VectorX m = lumpedMasses(mesh, rest, 0.25);
  EXPECT_NEAR(m.sum(), 0.25 * 1.2 * 0.8, 1e-12);
  // Alternating diagonals give interior vertices 4 or 8 incident triangles of area dx*dy/2,
  // each giving a third of its mass: vertex (4, 3) has 4, vertex (4, 4) has 8.
  const double dx = 1.2 / 6, dy = 0.8 / 8;
  EXPECT_NEAR(m[4 * 7 + 3], 0.25 * 4 * dx * dy / 6, 1e-14);
  EXPECT_NEAR(m[4 * 7 + 4], 0.25 * 8 * dx * dy / 6, 1e-14);
}

TEST(Grid, DiagonalsAlternate) {
  // Count the two diagonal directions: a biased mesh would use only one.
  GridSpec spec;
  spec.rows = 5;
  spec.cols = 5;
  const Mesh mesh = *makeGrid(spec);
  int rising = 0, falling = 0;
  for (const auto& e : uniqueEdges(mesh.triangles)) {
    const int r0 = e[0] / 5, c0 = e[0] % 5, r1 = e[1] / 5, c1 = e[1] % 5;
    if (r0 != r1 && c0 != c1) ((c1 - c0) * (r1 - r0) > 0 ? rising : falling)++;
  }
  EXPECT_EQ(rising, 8);
  EXPECT_EQ(falling, 8);
}

TEST(Grid, PlanesAndPlanar) {
  GridSpec spec;
  spec.plane = GridPlane::XZ;
  spec.origin = {1.0, 2.0, 3.0};
  const Mesh mesh = *makeGrid(spec);
  // Vertex 3 = (r 1, c 1): x = 1 + 1, y = 2, z = 3 + 1.
  EXPECT_DOUBLE_EQ(mesh.restPositions[9], 2.0);
  EXPECT_DOUBLE_EQ(mesh.restPositions[10], 2.0);
  EXPECT_DOUBLE_EQ(mesh.restPositions[11], 4.0);
  spec.dim = 2;
  const Mesh planar = *makeGrid(spec);
  EXPECT_EQ(planar.dim, 2);
  EXPECT_EQ(planar.restPositions.size(), 8);
  // Counter-clockwise triangles have positive signed area.
  for (Index t = 0; t < planar.numTriangles(); ++t) {
    EXPECT_GT(triangleArea(planar, planar.restPositions, t, true), 0.0);
  }
}

TEST(Grid, RejectsBadSpecs) {
  GridSpec spec;
  spec.rows = 1;
  EXPECT_FALSE(makeGrid(spec).ok());
  EXPECT_NE(makeGrid(spec).error().find("rows = 1"), std::string::npos);
  spec.rows = 3;
  spec.width = -1.0;
  EXPECT_FALSE(makeGrid(spec).ok());
  spec.width = 1.0;
  spec.dim = 4;
  EXPECT_FALSE(makeGrid(spec).ok());
}

TEST(Obj, QuadsAreSplitAndSlashFormsAccepted) {
  const std::string text =
      "# a unit square as one quad\n"
      "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
      "vt 0 0\n"
      "f 1/1 2/1 3/1 4/1\n";
  const Expected<Mesh> mesh = parseObj(text);
  ASSERT_TRUE(mesh.ok()) << mesh.error();
  EXPECT_EQ(mesh->numTriangles(), 2);
  EXPECT_NEAR(triangleArea(*mesh, mesh->restPositions, 0) +
                  triangleArea(*mesh, mesh->restPositions, 1),
              1.0, 1e-15);
  const Expected<Mesh> relative = parseObj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n");
  ASSERT_TRUE(relative.ok()) << relative.error();
  EXPECT_EQ(relative->triangles[0], (Triangle{0, 1, 2}));
}

TEST(Obj, ErrorsNameTheLine) {
  const Expected<Mesh> outOfRange = parseObj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", 3, "cloth.obj");
  ASSERT_FALSE(outOfRange.ok());
  EXPECT_NE(outOfRange.error().find("cloth.obj:4"), std::string::npos) << outOfRange.error();
  EXPECT_NE(outOfRange.error().find("vertex index 4 out of range"), std::string::npos);
  const Expected<Mesh> nan = parseObj("v 0 nan 0\n");
  ASSERT_FALSE(nan.ok());
  EXPECT_NE(nan.error().find("non-finite"), std::string::npos) << nan.error();
  EXPECT_FALSE(parseObj("v 0 0 0\nv 1 0 0\nv 0 1 0\n").ok());
  EXPECT_FALSE(parseObj("v 0 0 x\n").ok());
  EXPECT_FALSE(parseObj("v 0 0 0\nv 1 0 0\nv 0 1 1\nf 1 2 3\n", 2).ok());
  EXPECT_FALSE(loadObj("/nonexistent/cloth.obj").ok());
  EXPECT_NE(loadObj("/nonexistent/cloth.obj").error().find("/nonexistent/cloth.obj"),
            std::string::npos);
}

TEST(Obj, LoadsFromFile) {
  const std::string path = testing::TempDir() + "fem_cloth_test_triangle.obj";
  {
    std::ofstream out(path);
    out << "v 0 0 0\nv 2 0 0\nv 0 2 0\nf 1 2 3\n";
  }
  const Expected<Mesh> mesh = loadObj(path, 2);
  std::remove(path.c_str());
  ASSERT_TRUE(mesh.ok()) << mesh.error();
  EXPECT_EQ(mesh->dim, 2);
  EXPECT_NEAR(triangleArea(*mesh, mesh->restPositions, 0), 2.0, 1e-15);
}

TEST(Validation, NamesTheCulprit) {
  Mesh mesh;
  mesh.dim = 3;
  mesh.restPositions.resize(3 * 5);
  mesh.restPositions << 0, 0, 0, 1, 0, 0, 0, 1, 0, 2, 0, 0, 3, 0, 0;
  mesh.triangles = {{0, 1, 2}, {2, 1, 0}, {0, 1, 7}, {0, 0, 2}, {0, 1, 3}};
  const MeshValidation report = validateMesh(mesh);
  EXPECT_FALSE(report.ok());
  EXPECT_TRUE(anyContains(report.errors, "triangle 1 (2, 1, 0): repeats triangle 0"));
  EXPECT_TRUE(anyContains(report.errors, "triangle 2 (0, 1, 7): vertex index 7 out of range"));
  EXPECT_TRUE(anyContains(report.errors, "triangle 3 (0, 0, 2): repeats a vertex"));
  // Vertices 0, 1, 3 are collinear: zero area.
  EXPECT_TRUE(anyContains(report.errors, "triangle 4 (0, 1, 3): degenerate"));
  // Vertex 4 is in no triangle: it would have no mass, an error naming it (and its OBJ number).
  EXPECT_TRUE(anyContains(report.errors, "vertex 4 (number 5 in an OBJ file) belongs to no triangle"));
  EXPECT_NE(report.errorSummary().find("triangle 1"), std::string::npos);
}

TEST(Validation, NearDegenerateAndNonFinite) {
  Mesh mesh;
  mesh.dim = 2;
  mesh.restPositions.resize(6);
  // Height 1e-6 on a unit base: quality = 4 sqrt3 (0.5e-6) / (1 + 2*0.25) ~ 2.3e-6.
  mesh.restPositions << 0, 0, 1, 0, 0.5, 1e-6;
  mesh.triangles = {{0, 1, 2}};
  EXPECT_NEAR(triangleQuality(mesh, 0), 4 * std::sqrt(3.0) * 0.5e-6 / 1.5, 1e-9);
  EXPECT_FALSE(validateMesh(mesh).ok());
  EXPECT_TRUE(validateMesh(mesh, 1e-7).ok());
  EXPECT_TRUE(anyContains(validateMesh(mesh, 1e-7).warnings, "poorly shaped"));
  mesh.restPositions[3] = std::nan("");
  EXPECT_TRUE(anyContains(validateMesh(mesh).errors, "vertex 1 has a non-finite coordinate"));
}

TEST(Validation, NonManifoldEdgeIsWarned) {
  Mesh mesh;
  mesh.dim = 3;
  mesh.restPositions.resize(15);
  mesh.restPositions << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1;
  mesh.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  const MeshValidation report = validateMesh(mesh);
  EXPECT_TRUE(report.ok());
  EXPECT_TRUE(anyContains(report.warnings, "edge (0, 1) is non-manifold: shared by 3 triangles"));
}

TEST(RestState, FrameAndDmInverse) {
  // A triangle tilted out of the xy plane: rest data must not depend on the embedding.
  Mesh mesh;
  mesh.dim = 3;
  mesh.restPositions.resize(9);
  mesh.restPositions << 1, 1, 1, 1, 3, 1, 1, 1, 4;  // legs 2 (along y) and 3 (along z)
  mesh.triangles = {{0, 1, 2}};
  const RestState rest = *computeRestState(mesh);
  EXPECT_NEAR(rest.restArea[0], 3.0, 1e-14);
  const Eigen::Matrix<double, 3, 2> T = rest.tangentFrame[0];
  EXPECT_NEAR((T.transpose() * T - Eigen::Matrix2d::Identity()).norm(), 0.0, 1e-14);
  // F at rest is T (the rest frame embedded): F = Ds Dm^-1 maps the rest 2D frame to 3D.
  const DefGrad<3> F = deformationGradient<3>(mesh, rest, mesh.restPositions, 0);
  EXPECT_NEAR((F - T).norm(), 0.0, 1e-14);
  // Shape gradients sum to zero (translations do not deform).
  EXPECT_NEAR(rest.shapeGradients[0].colwise().sum().norm(), 0.0, 1e-14);
}
