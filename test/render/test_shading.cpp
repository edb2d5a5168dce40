// Vertex normals, vertex averages, the two-sided light and obstacle meshes against hand
// calculations.
#include <gtest/gtest.h>

#include "fem_cloth/render/shading.h"
#include "fem_cloth/render/shape_mesh.h"

using namespace fem_cloth;

namespace {

Mesh explicitMesh(const std::vector<Eigen::Vector3d>& points, std::vector<Triangle> triangles) {
  Mesh m;
  m.dim = 3;
  m.restPositions.resize(3 * static_cast<Index>(points.size()));
  for (std::size_t i = 0; i < points.size(); ++i) m.restPositions.segment<3>(3 * i) = points[i];
  m.triangles = std::move(triangles);
  return m;
}

}  // namespace

TEST(Shading, AFlatSheetHasOneNormalEverywhere) {
  GridSpec spec;  // 6 x 7 vertices over 0.5 m x 0.3 m, 0.75 m up
  spec.rows = 6, spec.cols = 7, spec.width = 0.5, spec.height = 0.3, spec.origin = {0.2, -0.1, 0.75};
  const Mesh mesh = *makeGrid(spec);
  std::vector<Eigen::Vector3d> n;
  vertexNormals(mesh, mesh.restPositions, n);
  ASSERT_EQ(n.size(), 42u);
  for (const Eigen::Vector3d& v : n) {
    EXPECT_NEAR(std::abs(v.z()), 1.0, 1e-12);
    EXPECT_NEAR((v - n[0]).norm(), 0.0, 1e-12) << "all equal (one orientation over the grid)";
  }
  // Tilted by a rotation, the sheet's normals turn with it.
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 0.5).normalized()).toRotationMatrix();
  VectorX x = mesh.restPositions;
  for (Index i = 0; i < mesh.numVertices(); ++i) x.segment<3>(3 * i) = R * x.segment<3>(3 * i);
  std::vector<Eigen::Vector3d> turned;
  vertexNormals(mesh, x, turned);
  for (const Eigen::Vector3d& v : turned) EXPECT_NEAR((v - R * n[0]).norm(), 0.0, 1e-12);
}

TEST(Shading, VertexNormalsAreAreaWeighted) {
  // An open book: triangle A in the xy plane (legs 1, 1: area 1/2, normal +z) and triangle B in
  // the xz plane (legs 2, 2: area 2, normal of (0,0,0),(2,0,0),(0,0,2) is (2,0,0) x (0,0,2) =
  // (0,-4,0)), sharing the edge from the origin along x. At a shared vertex the weighted sum is
  // 2 (1/2) (0,0,1) + 2 (2) (0,-1,0) = (0, -4, 1), normalised; at A's own vertex +z, at B's -y.
  const Mesh m = explicitMesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 2}, {2, 0, 0}},
                              {{0, 1, 2}, {0, 4, 3}});
  std::vector<Eigen::Vector3d> n;
  vertexNormals(m, m.restPositions, n);
  const Eigen::Vector3d shared = Eigen::Vector3d(0, -4, 1) / std::sqrt(17.0);
  EXPECT_NEAR((n[0] - shared).norm(), 0.0, 1e-12);
  EXPECT_NEAR((n[2] - Eigen::Vector3d(0, 0, 1)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((n[3] - Eigen::Vector3d(0, -1, 0)).norm(), 0.0, 1e-12);
  // Vertex 1 is only in A, vertex 4 only in B.
  EXPECT_NEAR((n[1] - Eigen::Vector3d(0, 0, 1)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((n[4] - Eigen::Vector3d(0, -1, 0)).norm(), 0.0, 1e-12);
  // Averages of per-triangle values, weighted by area: (0.5 * 1 + 2 * 3) / 2.5 = 2.6 at vertex 0.
  std::vector<double> avg;
  vertexAverages(m, m.restPositions, {1.0, 3.0}, avg);
  EXPECT_NEAR(avg[0], 2.6, 1e-12);
  EXPECT_NEAR(avg[2], 1.0, 1e-12);
  EXPECT_NEAR(avg[3], 3.0, 1e-12);
}

TEST(Shading, ACollapsedOrUnusedVertexGetsPlusZ) {
  const Mesh m = explicitMesh({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {5, 5, 5}}, {{0, 1, 2}});
  std::vector<Eigen::Vector3d> n;
  vertexNormals(m, m.restPositions, n);
  for (const Eigen::Vector3d& v : n) EXPECT_EQ(v, Eigen::Vector3d::UnitZ());
}

TEST(Shading, TheLightIsLambertianAndTwoSided) {
  Light light;
  light.direction = Eigen::Vector3d(0, 0, 2);  // normalised where used
  light.ambient = 0.3f;
  light.diffuse = 0.6f;
  const Colour base(0.5f, 1.0f, 0.25f);
  // Facing the light: 0.3 + 0.6 = 0.9 of the base; the back side the same; at 60 degrees
  // cos = 1/2: 0.6 of the base; edge-on: the ambient 0.3.
  EXPECT_TRUE(shade(base, {0, 0, 1}, light).isApprox(0.9f * base));
  EXPECT_TRUE(shade(base, {0, 0, -1}, light).isApprox(0.9f * base));
  EXPECT_TRUE(shade(base, {std::sqrt(3.0) / 2, 0, 0.5}, light).isApprox(0.6f * base, 1e-6f));
  EXPECT_TRUE(shade(base, {1, 0, 0}, light).isApprox(0.3f * base));
  // Never brighter than white.
  light.ambient = 1.0f;
  EXPECT_TRUE(shade(Colour(1, 1, 1), {0, 0, 1}, light).isApprox(Colour(1, 1, 1)));
}

TEST(Shading, StrainColoursRunFromBlueThroughWhiteToRed) {
  EXPECT_TRUE(strainColour(0.0, 0.05).isApprox(Colour(0.15f, 0.35f, 1.0f)));
  EXPECT_TRUE(strainColour(-0.1, 0.05).isApprox(Colour(0.15f, 0.35f, 1.0f))) << "compression: as unstrained";
  EXPECT_TRUE(strainColour(0.025, 0.05).isApprox(Colour(1.0f, 1.0f, 1.0f)));
  EXPECT_TRUE(strainColour(0.05, 0.05).isApprox(Colour(1.0f, 0.2f, 0.15f)));
  EXPECT_TRUE(strainColour(1.0, 0.05).isApprox(Colour(1.0f, 0.2f, 0.15f)));
}

TEST(Shading, ClothColoursOfAStretchedSheet) {
  // A sheet stretched 2 % along x: every triangle's largest principal stretch is 1.02, so every
  // vertex has strain 0.02 and, by strain on a 0.04 scale, the white of the middle; flat, so all
  // get the same light.
  GridSpec spec;
  spec.rows = 4;
  spec.cols = 4;
  const Mesh mesh = *makeGrid(spec);
  const RestState rest = *computeRestState(mesh);
  VectorX x = mesh.restPositions;
  for (Index i = 0; i < mesh.numVertices(); ++i) x[3 * i] *= 1.02;
  std::vector<Eigen::Vector3d> n;
  vertexNormals(mesh, x, n);
  ClothLook look;
  look.byStrain = true;
  look.strainColourMax = 0.04;
  std::vector<Colour> colours;
  clothVertexColours(mesh, rest, x, n, look, colours);
  const Colour lit = shade(Colour(1, 1, 1), Eigen::Vector3d::UnitZ(), look.light);
  for (const Colour& c : colours) EXPECT_TRUE(c.isApprox(lit, 1e-5f)) << c.transpose();
  look.byStrain = false;
  clothVertexColours(mesh, rest, x, n, look, colours);
  for (const Colour& c : colours) EXPECT_TRUE(c.isApprox(shade(look.colour, Eigen::Vector3d::UnitZ(), look.light)));
}

TEST(ShapeMesh, BoxesAndSpheresLieOnTheirSurfaces) {
  Shape box;
  box.type = ShapeType::Box;
  box.halfExtents = {0.5, 0.6, 0.375};
  const ShapeMesh b = tessellate(box, 0.0);
  EXPECT_EQ(b.triangles.size(), 12u);
  for (std::size_t k = 0; k < b.positions.size(); ++k) {
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(std::abs(b.positions[k][a]), box.halfExtents[a], 1e-15);
    // The normal is the axis of the face the vertex belongs to, pointing out.
    EXPECT_NEAR(b.normals[k].dot(b.positions[k].cwiseQuotient(box.halfExtents)), 1.0, 1e-12);
  }
  Shape sphere;
  sphere.type = ShapeType::Sphere;
  sphere.radius = 0.25;
  const ShapeMesh s = tessellate(sphere, 0.0, 16);
  for (std::size_t k = 0; k < s.positions.size(); ++k) {
    EXPECT_NEAR(s.positions[k].norm(), 0.25, 1e-12);
    EXPECT_NEAR((s.normals[k] - s.positions[k] / 0.25).norm(), 0.0, 1e-12);
  }
  Shape capsule;
  capsule.type = ShapeType::Capsule;
  capsule.radius = 0.1;
  capsule.halfLength = 0.3;
  const ShapeMesh c = tessellate(capsule, 0.0, 16);
  for (std::size_t k = 0; k < c.positions.size(); ++k) {
    // Distance to the axis segment from (0, 0, -0.3) to (0, 0, 0.3) is the radius.
    const Eigen::Vector3d p = c.positions[k];
    const Eigen::Vector3d onAxis(0, 0, std::clamp(p.z(), -0.3, 0.3));
    EXPECT_NEAR((p - onAxis).norm(), 0.1, 1e-12);
  }
  Shape plane;
  const ShapeMesh p = tessellate(plane, 8.0);
  ASSERT_EQ(p.positions.size(), 4u);
  for (const Eigen::Vector3d& q : p.positions) {
    EXPECT_EQ(q.z(), 0.0);
    EXPECT_EQ(std::abs(q.x()), 4.0);
    EXPECT_EQ(std::abs(q.y()), 4.0);
  }
}
