// Perception outputs of the node (perception.test: the small cloth, paused, a 160 x 120 camera
// 2 m above it with a 1.2 rad horizontal field of view). After 20 steps the cloth sags from
// its pinned edge; the test checks, independently of the node's renderer:
//   - ~points holds every vertex of ~state, with unit normals;
//   - CameraInfo has the intrinsics the parameters ask for (fx = (w/2) / tan(fov/2));
//   - at the pixel where each interior vertex projects (the camera's pose from tf, the
//     projection from those intrinsics, computed here), the depth image reads the vertex's z in
//     the optical frame to within one pixel's depth step (the depth change across a pixel,
//     from the vertex's neighbours' projections), and the colour image shows the cloth;
//   - a pixel that sees nothing reads NaN and the background colour;
//   - the scene's frames `corner` (vertex 0) and `free_corner` (grid (-1, -1)) are in tf at the
//     state's stamp, at the vertices' positions.
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <shape_msgs/Mesh.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <cstring>
#include <set>

#include "fem_cloth/Advance.h"
#include "node_test_support.h"

using namespace fem_cloth_test;

namespace {

constexpr int kWidth = 160, kHeight = 120;
constexpr double kFov = 1.2;  // rad, horizontal
constexpr std::uint32_t kSteps = 20;

Eigen::Vector3d point(const geometry_msgs::Point& p) { return {p.x, p.y, p.z}; }

float depthAt(const sensor_msgs::Image& image, int i, int j) {
  float z = 0.0f;
  std::memcpy(&z, &image.data[j * image.step + 4 * i], 4);
  return z;
}

}  // namespace

TEST(Perception, PointsDepthAndFramesMatchTheState) {
  tf2_ros::Buffer tf;
  tf2_ros::TransformListener listener(tf);
  Latest<fem_cloth::ClothState> state(topic("state"));
  Latest<shape_msgs::Mesh> mesh(topic("mesh"));
  Latest<sensor_msgs::PointCloud2> points(topic("points"));
  Latest<sensor_msgs::Image> depth(topic("camera/depth/image")), colour(topic("camera/color/image"));
  Latest<sensor_msgs::CameraInfo> info(topic("camera/depth/camera_info"));
  ASSERT_TRUE(state.waitConnected() && mesh.waitConnected() && points.waitConnected() &&
              depth.waitConnected() && colour.waitConnected() && info.waitConnected());
  ros::NodeHandle nh;
  ros::ServiceClient advance = nh.serviceClient<fem_cloth::Advance>(topic("advance"));
  ASSERT_TRUE(advance.waitForExistence(ros::Duration(10.0)));
  fem_cloth::Advance call;
  call.request.steps = kSteps;
  ASSERT_TRUE(advance.call(call) && call.response.success) << call.response.message;

  const auto s = state.waitFor([](const fem_cloth::ClothState& m) { return m.step == kSteps; });
  ASSERT_TRUE(s);
  const ros::Time stamp = s->header.stamp;
  auto sameStamp = [stamp](const auto& m) { return m.header.stamp == stamp; };
  const auto cloud = points.waitFor(sameStamp);
  const auto d = depth.waitFor(sameStamp);
  const auto c = colour.waitFor(sameStamp);
  const auto k = info.waitFor(sameStamp);
  const auto m = mesh.waitForAny();
  ASSERT_TRUE(cloud && d && c && k && m) << "no point cloud, image or camera info of step " << kSteps;
  const std::size_t n = s->positions.size();
  ASSERT_EQ(n, 81u);

  // The point cloud: vertex i is point i, as float.
  ASSERT_EQ(cloud->width * cloud->height, n);
  EXPECT_EQ(cloud->header.frame_id, "world");
  sensor_msgs::PointCloud2ConstIterator<float> px(*cloud, "x"), pn(*cloud, "normal_x");
  for (std::size_t i = 0; i < n; ++i, ++px, ++pn) {
    EXPECT_EQ(px[0], static_cast<float>(s->positions[i].x));
    EXPECT_EQ(px[1], static_cast<float>(s->positions[i].y));
    EXPECT_EQ(px[2], static_cast<float>(s->positions[i].z));
    EXPECT_NEAR(std::sqrt(pn[0] * pn[0] + pn[1] * pn[1] + pn[2] * pn[2]), 1.0, 1e-6);
  }

  // The intrinsics the parameters ask for.
  const double fx = 0.5 * kWidth / std::tan(0.5 * kFov), cx = 0.5 * (kWidth - 1), cy = 0.5 * (kHeight - 1);
  EXPECT_EQ(k->width, static_cast<std::uint32_t>(kWidth));
  EXPECT_EQ(k->height, static_cast<std::uint32_t>(kHeight));
  EXPECT_NEAR(k->K[0], fx, 1e-9);
  EXPECT_NEAR(k->K[4], fx, 1e-9);
  EXPECT_NEAR(k->K[2], cx, 1e-12);
  EXPECT_NEAR(k->K[5], cy, 1e-12);
  EXPECT_EQ(d->encoding, "32FC1");
  EXPECT_EQ(c->encoding, "rgb8");
  ASSERT_EQ(d->header.frame_id, "top_camera");
  ASSERT_EQ(d->width, static_cast<std::uint32_t>(kWidth));
  ASSERT_EQ(d->height, static_cast<std::uint32_t>(kHeight));

  // The camera's pose from tf (the node broadcasts it from ~camera/pose).
  ASSERT_TRUE(tf.canTransform("world", "top_camera", ros::Time(0), ros::Duration(10.0)));
  const Eigen::Isometry3d cameraFromWorld =
      tf2::transformToEigen(tf.lookupTransform("top_camera", "world", ros::Time(0)));
  auto project = [&](std::size_t v) {
    const Eigen::Vector3d p = cameraFromWorld * point(s->positions[v]);
    return Eigen::Vector3d(fx * p.x() / p.z() + cx, fx * p.y() / p.z() + cy, p.z());
  };
  // Neighbours from the mesh's triangles; interior vertices of the 9 x 9 grid only (an edge
  // vertex's pixel may fall just off the cloth).
  std::vector<std::set<std::size_t>> neighbours(n);
  for (const auto& t : m->triangles) {
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) {
        if (a != b) neighbours[t.vertex_indices[a]].insert(t.vertex_indices[b]);
      }
    }
  }
  int checked = 0;
  for (std::size_t v = 0; v < n; ++v) {
    const std::size_t row = v / 9, col = v % 9;
    if (row == 0 || row == 8 || col == 0 || col == 8) continue;
    const Eigen::Vector3d q = project(v);
    const int i = static_cast<int>(std::lround(q.x())), j = static_cast<int>(std::lround(q.y()));
    if (i < 0 || j < 0 || i >= kWidth || j >= kHeight) continue;
    double step = 0.0;  // depth change per pixel around the vertex (m)
    for (std::size_t w : neighbours[v]) {
      const Eigen::Vector3d r = project(w);
      step = std::max(step, std::abs(r.z() - q.z()) / (r.head<2>() - q.head<2>()).norm());
    }
    EXPECT_NEAR(depthAt(*d, i, j), q.z(), step + 1e-6 * q.z()) << "vertex " << v << " at pixel " << i << ", " << j;
    const std::uint8_t* rgb = &c->data[j * c->step + 3 * i];
    EXPECT_FALSE(rgb[0] == 48 && rgb[1] == 48 && rgb[2] == 48) << "the cloth is shown at vertex " << v;
    ++checked;
  }
  EXPECT_GE(checked, 30) << "most interior vertices are in view";
  // The top-left corner of the image looks past the cloth's pinned edge (y < 0): nothing.
  EXPECT_TRUE(std::isnan(depthAt(*d, 0, 0)));
  EXPECT_EQ(c->data[0], 48);

  // Frames of cloth points at the state's stamp.
  for (const auto& [name, vertex] : {std::pair<std::string, std::size_t>{"corner", 0}, {"free_corner", 80}}) {
    ASSERT_TRUE(tf.canTransform("world", name, stamp, ros::Duration(10.0))) << name;
    const Eigen::Isometry3d T = tf2::transformToEigen(tf.lookupTransform("world", name, stamp));
    EXPECT_NEAR((T.translation() - point(s->positions[vertex])).norm(), 0.0, 1e-9) << name;
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_perception");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
