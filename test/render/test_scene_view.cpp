// SceneView: obstacles and the cloth placed in the world, seen through a camera pose, against
// hand calculations: a floor 2 m below a camera looking straight down reads 2 m at every pixel
// (a plane perpendicular to the optical axis has one depth) in the floor's shaded colour; a
// sphere straight ahead reads distance minus radius at the centre; a cloth in front of the
// sphere hides it where it covers it.
#include <gtest/gtest.h>

#include "fem_cloth/render/scene_view.h"

using namespace fem_cloth;

namespace {

const CameraIntrinsics kCamera = CameraIntrinsics::fromHorizontalFov(80, 60, 1.0);

}  // namespace

TEST(SceneView, AFloorSeenFromAboveHasOneDepth) {
  SceneView view(kCamera, 0.1, 10.0);
  const Eigen::Isometry3d camera = *lookAt({0.3, -0.2, 2.0}, {0.3, -0.2, 0.0}, Eigen::Vector3d::UnitY());
  PlacedShape floor;  // a plane: z = 0, normal +z
  const Mesh none;
  ViewStyle style;
  view.render(camera, none, VectorX(), {}, {floor}, style);
  // shade() of the plane colour with the normal +z, as bytes.
  const Colour c = shade(style.plane, Eigen::Vector3d::UnitZ(), style.light);
  for (int j = 0; j < kCamera.height; ++j) {
    for (int i = 0; i < kCamera.width; ++i) {
      ASSERT_NEAR(view.image().depthAt(i, j), 2.0, 1e-6) << i << ", " << j;
      const std::uint8_t* rgb = &view.image().rgb()[3 * (j * kCamera.width + i)];
      ASSERT_EQ(rgb[0], std::lround(255 * c.x()));
      ASSERT_EQ(rgb[2], std::lround(255 * c.z()));
    }
  }
}

TEST(SceneView, ASphereAheadAndAClothInFrontOfIt) {
  // The principal point on the centre of pixel (40, 30): its ray is the optical axis.
  CameraIntrinsics k = kCamera;
  k.cx = 40.0;
  k.cy = 30.0;
  SceneView view(k, 0.1, 10.0);
  // Camera at the origin looking along +x; a ball of radius 0.5 centred 3 m ahead.
  const Eigen::Isometry3d camera = *lookAt({0, 0, 0}, {1, 0, 0});
  PlacedShape ball;
  ball.shape.type = ShapeType::Sphere;
  ball.shape.radius = 0.5;
  ball.pose.translation() = Eigen::Vector3d(3.0, 0.0, 0.0);
  const Mesh none;
  view.render(camera, none, VectorX(), {}, {ball}, ViewStyle());
  // The axis meets the ball at its nearest point, 2.5 m ahead: a vertex of its tessellation.
  EXPECT_NEAR(view.image().depthAt(40, 30), 2.5, 1e-6);
  EXPECT_TRUE(std::isnan(view.image().depthAt(0, 0))) << "beside the ball: nothing";
  // A 0.4 m square of cloth 1 m ahead, facing the camera, covers the middle of the view.
  GridSpec spec;  // in the grid's xy plane, then turned to face -x at x = 1
  spec.rows = 3, spec.cols = 3, spec.width = 0.4, spec.height = 0.4, spec.plane = GridPlane::YZ;
  spec.origin = {1.0, -0.2, -0.2};
  const Mesh cloth = *makeGrid(spec);
  const std::vector<Colour> white(cloth.numVertices(), Colour(1, 1, 1));
  view.render(camera, cloth, cloth.restPositions, white, {ball}, ViewStyle());
  EXPECT_NEAR(view.image().depthAt(40, 30), 1.0, 1e-6) << "the cloth hides the ball";
  const std::uint8_t* rgb = &view.image().rgb()[3 * (30 * kCamera.width + 40)];
  EXPECT_EQ(rgb[0], 255);
  EXPECT_EQ(rgb[1], 255);
}
