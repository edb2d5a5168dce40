// The rasteriser against hand-computed cases: a triangle facing the camera at a known depth, a
// slanted plane whose depth follows from intersecting each pixel's ray with it, occlusion in
// both drawing orders, coverage against an independent point-in-triangle test, shared edges
// drawn once and without cracks, clipping at the near range, the far range, an empty background.
#include <gtest/gtest.h>

#include <cmath>

#include "fem_cloth/render/camera.h"
#include "fem_cloth/render/rasterizer.h"

using namespace fem_cloth;

namespace {

// fx = 64 and cx = 32 make projections of points at z = 1 with x a multiple of 1/64 exact.
CameraIntrinsics smallCamera() {
  CameraIntrinsics k;
  k.width = 64;
  k.height = 48;
  k.fx = k.fy = 64.0;
  k.cx = 32.0;
  k.cy = 24.0;
  return k;
}

const Colour kRed(1.0f, 0.0f, 0.0f), kBlue(0.0f, 0.0f, 1.0f), kGrey(0.2f, 0.2f, 0.2f);

std::array<Colour, 3> uniform(const Colour& c) { return {c, c, c}; }

// A point at depth z that projects to pixel coordinates (u, v) of smallCamera().
Eigen::Vector3d at(double u, double v, double z) {
  return {(u - 32.0) / 64.0 * z, (v - 24.0) / 64.0 * z, z};
}

int covered(const Rasterizer& r) {
  int n = 0;
  for (float z : r.depth()) n += std::isnan(z) ? 0 : 1;
  return n;
}

}  // namespace

TEST(Camera, FieldOfViewAndLookAt) {
  // 90 degrees across 640 pixels: tan(45 deg) = 1, so fx = 320; centre (319.5, 239.5).
  const CameraIntrinsics k = CameraIntrinsics::fromHorizontalFov(640, 480, M_PI / 2);
  EXPECT_NEAR(k.fx, 320.0, 1e-9);
  EXPECT_NEAR(k.fy, 320.0, 1e-9);
  EXPECT_DOUBLE_EQ(k.cx, 319.5);
  EXPECT_DOUBLE_EQ(k.cy, 239.5);
  EXPECT_TRUE(k.validate());
  CameraIntrinsics bad = k;
  bad.fx = 0.0;
  EXPECT_FALSE(bad.validate());
  bad = k;
  bad.width = 0;
  EXPECT_FALSE(bad.validate());
  // Looking along +x with +z up: image right is -y, image down is -z (REP-103 optical frame).
  const auto pose = lookAt({0, 0, 0}, {2, 0, 0});
  ASSERT_TRUE(pose);
  EXPECT_TRUE(pose->linear().col(2).isApprox(Eigen::Vector3d(1, 0, 0)));
  EXPECT_TRUE(pose->linear().col(0).isApprox(Eigen::Vector3d(0, -1, 0)));
  EXPECT_TRUE(pose->linear().col(1).isApprox(Eigen::Vector3d(0, 0, -1)));
  EXPECT_FALSE(lookAt({0, 0, 0}, {0, 0, 0}));
  EXPECT_FALSE(lookAt({0, 0, 0}, {0, 0, -1})) << "straight down along up: no defined image rotation";
}

TEST(Rasterizer, BackgroundIsNaNAndTheBackgroundColour) {
  Rasterizer r(smallCamera(), 0.1, 10.0);
  r.clear(kGrey);
  for (float z : r.depth()) EXPECT_TRUE(std::isnan(z));
  // 0.2 * 255 = 51.
  for (std::uint8_t c : r.rgb()) EXPECT_EQ(c, 51);
  // Behind the camera: nothing drawn.
  r.drawTriangle({Eigen::Vector3d(-1, -1, -2), Eigen::Vector3d(1, -1, -2), Eigen::Vector3d(0, 1, -2)},
                 uniform(kRed));
  EXPECT_EQ(covered(r), 0);
}

TEST(Rasterizer, ATriangleFacingTheCameraReadsItsDepth) {
  Rasterizer r(smallCamera(), 0.1, 10.0);
  r.clear(kGrey);
  r.drawTriangle({at(10, 10, 2.5), at(50, 10, 2.5), at(30, 40, 2.5)}, uniform(kRed));
  // Pixel (30, 20) is well inside: depth 2.5 exactly, red.
  EXPECT_EQ(r.depthAt(30, 20), 2.5f);
  const std::size_t k = 3 * (20 * 64 + 30);
  EXPECT_EQ(r.rgb()[k], 255);
  EXPECT_EQ(r.rgb()[k + 1], 0);
  EXPECT_EQ(r.rgb()[k + 2], 0);
  // A pixel outside the triangle: still background.
  EXPECT_TRUE(std::isnan(r.depthAt(5, 5)));
  EXPECT_TRUE(std::isnan(r.depthAt(55, 40)));
  EXPECT_EQ(r.rgb()[3 * (5 * 64 + 5)], 51);
}

TEST(Rasterizer, CoverageMatchesAnIndependentInsideTest) {
  // Vertices off the pixel grid; a pixel centre is inside when its barycentric coordinates
  // (from the projected vertices, computed here) are all positive. Centres within 1e-9 of an
  // edge are left out of the comparison (the tie rule decides them).
  const Eigen::Vector2d a(7.3, 5.1), b(55.7, 12.4), c(21.9, 44.6);
  Rasterizer r(smallCamera(), 0.1, 10.0);
  r.clear(kGrey);
  r.drawTriangle({at(a.x(), a.y(), 3.0), at(b.x(), b.y(), 3.0), at(c.x(), c.y(), 3.0)}, uniform(kRed));
  const auto cross = [](const Eigen::Vector2d& p, const Eigen::Vector2d& q) { return p.x() * q.y() - p.y() * q.x(); };
  const double area = cross(b - a, c - a);
  int compared = 0;
  for (int j = 0; j < 48; ++j) {
    for (int i = 0; i < 64; ++i) {
      const Eigen::Vector2d q(i, j);
      const double l0 = cross(c - b, q - b) / area, l1 = cross(a - c, q - c) / area,
                   l2 = cross(b - a, q - a) / area;
      if (std::min({std::abs(l0), std::abs(l1), std::abs(l2)}) < 1e-9) continue;
      const bool inside = l0 > 0 && l1 > 0 && l2 > 0;
      EXPECT_EQ(!std::isnan(r.depthAt(i, j)), inside) << "pixel " << i << ", " << j;
      ++compared;
    }
  }
  EXPECT_GT(compared, 3000);
}

TEST(Rasterizer, ASlantedPlaneHasTheDepthOfEachPixelsRay) {
  // The plane z = 2 + x / 2. Pixel (i, j)'s ray is t ((i - cx)/fx, (j - cy)/fy, 1), which meets
  // it at z = t = 2 / (1 - (i - cx) / (2 fx)). The triangle's vertices lie in the plane.
  auto onPlane = [](double x, double y) { return Eigen::Vector3d(x, y, 2.0 + 0.5 * x); };
  Rasterizer r(smallCamera(), 0.1, 10.0);
  r.clear(kGrey);
  r.drawTriangle({onPlane(-1.5, -1.5), onPlane(1.5, -1.5), onPlane(0.0, 1.5)}, uniform(kBlue));
  int checked = 0;
  for (int j = 0; j < 48; ++j) {
    for (int i = 0; i < 64; ++i) {
      if (std::isnan(r.depthAt(i, j))) continue;
      const double expected = 2.0 / (1.0 - (i - 32.0) / (2.0 * 64.0));
      EXPECT_NEAR(r.depthAt(i, j), expected, 1e-6 * expected) << "pixel " << i << ", " << j;
      ++checked;
    }
  }
  EXPECT_GT(checked, 500);
}

TEST(Rasterizer, TheNearerSurfaceWinsInEitherOrder) {
  const std::array<Eigen::Vector3d, 3> nearT = {at(5, 5, 1.0), at(60, 5, 1.0), at(32, 45, 1.0)};
  const std::array<Eigen::Vector3d, 3> farT = {at(0, 0, 3.0), at(63, 0, 3.0), at(32, 47, 3.0)};
  for (bool nearFirst : {true, false}) {
    Rasterizer r(smallCamera(), 0.1, 10.0);
    r.clear(kGrey);
    if (nearFirst) {
      r.drawTriangle(nearT, uniform(kRed));
      r.drawTriangle(farT, uniform(kBlue));
    } else {
      r.drawTriangle(farT, uniform(kBlue));
      r.drawTriangle(nearT, uniform(kRed));
    }
    EXPECT_EQ(r.depthAt(32, 20), 1.0f);
    EXPECT_EQ(r.rgb()[3 * (20 * 64 + 32)], 255) << "red in front";
    EXPECT_EQ(r.rgb()[3 * (20 * 64 + 32) + 2], 0);
    // Beside the near triangle, the far one shows.
    EXPECT_EQ(r.depthAt(2, 1), 3.0f);
  }
}

TEST(Rasterizer, ASharedEdgeIsDrawnOnceWithoutCracks) {
  // The square [10, 20] x [10, 20] in pixel coordinates as two triangles whose shared diagonal
  // passes exactly through the centres (k, k): together they cover every centre strictly inside
  // the square and those on the diagonal, and no centre twice.
  const std::array<Eigen::Vector3d, 3> lower = {at(10, 10, 1.0), at(20, 10, 1.0), at(20, 20, 1.0)};
  const std::array<Eigen::Vector3d, 3> upper = {at(10, 10, 1.0), at(20, 20, 1.0), at(10, 20, 1.0)};
  Rasterizer a(smallCamera(), 0.1, 10.0), b(smallCamera(), 0.1, 10.0), both(smallCamera(), 0.1, 10.0);
  for (Rasterizer* r : {&a, &b, &both}) r->clear(kGrey);
  a.drawTriangle(lower, uniform(kRed));
  b.drawTriangle(upper, uniform(kRed));
  both.drawTriangle(lower, uniform(kRed));
  both.drawTriangle(upper, uniform(kRed));
  EXPECT_EQ(covered(a) + covered(b), covered(both)) << "a pixel drawn by both triangles";
  for (int j = 11; j < 20; ++j) {
    for (int i = 11; i < 20; ++i) EXPECT_FALSE(std::isnan(both.depthAt(i, j))) << i << ", " << j;
  }
  // Each square side belongs to the square or its neighbour: 10 x 10 of the 11 x 11 centres.
  EXPECT_EQ(covered(both), 100);
}

TEST(Rasterizer, AFloorReachingBehindTheCameraIsClippedAtTheNearRange) {
  // The plane y = 1 (1 m below the optical centre; y is down), from 5 m behind to 10 m ahead.
  // Row j > cy sees it at z = fy / (j - cy); rows above the horizon see nothing.
  Rasterizer r(smallCamera(), 0.1, 100.0);
  r.clear(kGrey);
  r.drawTriangle({Eigen::Vector3d(-50, 1, -5), Eigen::Vector3d(50, 1, -5), Eigen::Vector3d(0, 1, 10)},
                 uniform(kRed));
  for (int j = 0; j < 48; ++j) {
    const float z = r.depthAt(32, j);
    if (j <= 24 + 6) {
      // At j - cy <= 6 the plane is at z >= 64/6 > 10 m: beyond the triangle's far vertex.
      if (j <= 24) {
        EXPECT_TRUE(std::isnan(z)) << "row " << j << " is above the horizon";
      }
      continue;
    }
    EXPECT_NEAR(z, 64.0 / (j - 24.0), 1e-5 * z) << "row " << j;
  }
  // The nearest rows (j = 47: z = 64/23 = 2.8 m) are drawn: the part behind the camera was cut.
  EXPECT_FALSE(std::isnan(r.depthAt(32, 47)));
}

TEST(Rasterizer, NothingBeyondTheFarRange) {
  Rasterizer r(smallCamera(), 0.1, 10.0);
  r.clear(kGrey);
  r.drawTriangle({at(5, 5, 20.0), at(60, 5, 20.0), at(32, 45, 20.0)}, uniform(kRed));
  EXPECT_EQ(covered(r), 0);
  // Partly beyond: from 5 m at the left edge of the image to 15 m at its right; the near part is
  // drawn, nothing farther than 10 m is.
  r.drawTriangle({at(0, 0, 5.0), at(63, 24, 15.0), at(0, 47, 5.0)}, uniform(kRed));
  EXPECT_FALSE(std::isnan(r.depthAt(2, 24)));
  for (float z : r.depth()) {
    // Braces: EXPECT_LE expands to an if/else of its own (-Wdangling-else).
    if (!std::isnan(z)) {
      EXPECT_LE(z, 10.0f);
    }
  }
}
