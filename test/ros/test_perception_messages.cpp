// The perception message builders without a master: the point cloud's layout read back with
// sensor_msgs' own iterators, image and CameraInfo contents, tf frames of cloth points (the
// scene's `frames`, by vertex and by grid coordinates, and their tangent frames), the marker.
#include <gtest/gtest.h>
#include <sensor_msgs/image_encodings.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include <cstring>

#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/ros/perception.h"
#include "fem_cloth/ros/perception_messages.h"
#include "fem_cloth/ros/scene_params.h"

using namespace fem_cloth;

namespace {

const char* kScene = R"(
name: frames
mesh: {type: grid, rows: 3, cols: 4, width: 0.3, height: 0.2, origin: [1.0, 2.0, 0.5]}
material: {model: stvk, youngs_modulus: 2.0e6, poisson_ratio: 0.3, thickness: 5.0e-4, density: 2000}
frames:
  - {name: first, vertex: 0}
  - {name: last, grid_vertex: [-1, -1]}
  - {name: middle, grid_vertex: [1, 2]}
)";

Scene scene(const std::string& extra = "") { return *parseScene(YAML::Load(std::string(kScene) + extra)); }

}  // namespace

TEST(PointCloud, CarriesEveryVertexWithTheChosenFields) {
  const Scene s = scene();
  const Mesh mesh = *makeGrid(s.grid);
  const Index n = mesh.numVertices();
  VectorX x = mesh.restPositions, v(3 * n);
  for (Index i = 0; i < 3 * n; ++i) v[i] = 0.01 * i - 0.2;
  std::vector<Eigen::Vector3d> normals(n);
  std::vector<double> strains(n);
  for (Index i = 0; i < n; ++i) {
    normals[i] = Eigen::Vector3d(i, 1.0, -2.0).normalized();
    strains[i] = 0.001 * i;
  }
  std_msgs::Header h;
  h.frame_id = "world";
  PointFields all{true, true, true};
  const sensor_msgs::PointCloud2 cloud = toPointCloud(h, mesh, x, all, normals, strains, v);
  EXPECT_EQ(cloud.header.frame_id, "world");
  EXPECT_EQ(cloud.height, 1u);
  EXPECT_EQ(cloud.width, 12u);
  // x y z, normal_x normal_y normal_z, strain, vx vy vz: 10 float32.
  ASSERT_EQ(cloud.fields.size(), 10u);
  EXPECT_EQ(cloud.point_step, 40u);
  EXPECT_EQ(cloud.row_step, 480u);
  EXPECT_EQ(cloud.data.size(), 480u);
  EXPECT_TRUE(cloud.is_dense);
  EXPECT_EQ(cloud.fields[6].name, "strain");
  EXPECT_EQ(cloud.fields[6].offset, 24u);
  sensor_msgs::PointCloud2ConstIterator<float> px(cloud, "x"), pn(cloud, "normal_x"),
      ps(cloud, "strain"), pv(cloud, "vx");
  for (Index i = 0; i < n; ++i, ++px, ++pn, ++ps, ++pv) {
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(px[k], static_cast<float>(x[3 * i + k])) << "vertex " << i;
      EXPECT_EQ(pn[k], static_cast<float>(normals[i][k]));
      EXPECT_EQ(pv[k], static_cast<float>(v[3 * i + k]));
    }
    EXPECT_EQ(*ps, static_cast<float>(strains[i]));
  }
  // Without options: x y z only, 12 bytes a point; the optional inputs are not read.
  const sensor_msgs::PointCloud2 plain = toPointCloud(h, mesh, x, PointFields{}, {}, {}, VectorX());
  ASSERT_EQ(plain.fields.size(), 3u);
  EXPECT_EQ(plain.point_step, 12u);
  float z5 = 0.0f;
  std::memcpy(&z5, &plain.data[5 * 12 + 8], 4);
  EXPECT_EQ(z5, 0.5f);
}

TEST(PointCloud, FieldNamesAreChecked) {
  EXPECT_TRUE(parsePointFields({"velocity", "normal"})->normal);
  EXPECT_FALSE(parsePointFields({"velocity", "normal"})->strain);
  const Expected<PointFields> bad = parsePointFields({"normal", "colour"});
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().find("'colour'"), std::string::npos) << bad.error();
}

TEST(CameraMessages, ImagesAndCameraInfo) {
  CameraIntrinsics k;  // 4 x 3 pixels, fx 100, fy 110, principal point (1.5, 1)
  k.width = 4, k.height = 3, k.fx = 100.0, k.fy = 110.0, k.cx = 1.5, k.cy = 1.0;
  std::vector<float> depth(12, std::numeric_limits<float>::quiet_NaN());
  depth[2 * 4 + 3] = 1.25f;  // column 3, row 2
  std_msgs::Header h;
  h.frame_id = "camera";
  const sensor_msgs::Image d = depthImageMessage(h, k, depth);
  EXPECT_EQ(d.encoding, sensor_msgs::image_encodings::TYPE_32FC1);
  EXPECT_EQ(d.step, 16u);
  ASSERT_EQ(d.data.size(), 48u);
  float value = 0.0f;
  std::memcpy(&value, &d.data[2 * d.step + 3 * 4], 4);
  EXPECT_EQ(value, 1.25f);
  std::memcpy(&value, &d.data[0], 4);
  EXPECT_TRUE(std::isnan(value)) << "nothing seen: NaN (REP-118)";
  const std::vector<std::uint8_t> rgb(36, 7);
  const sensor_msgs::Image c = colorImageMessage(h, k, rgb);
  EXPECT_EQ(c.encoding, sensor_msgs::image_encodings::RGB8);
  EXPECT_EQ(c.step, 12u);
  EXPECT_EQ(c.data, rgb);
  const sensor_msgs::CameraInfo info = cameraInfoMessage(h, k);
  EXPECT_EQ(info.header.frame_id, "camera");
  EXPECT_EQ(info.width, 4u);
  EXPECT_EQ(info.height, 3u);
  const boost::array<double, 9> K = {100, 0, 1.5, 0, 110, 1.0, 0, 0, 1};
  const boost::array<double, 12> P = {100, 0, 1.5, 0, 0, 110, 1.0, 0, 0, 0, 1, 0};
  EXPECT_EQ(info.K, K);
  EXPECT_EQ(info.P, P);
  EXPECT_EQ(info.D, std::vector<double>(5, 0.0));
}

TEST(ClothFrames, ResolvedByVertexAndByGridCoordinates) {
  const Scene s = scene();
  const Mesh mesh = *makeGrid(s.grid);
  const Expected<std::vector<ClothFrame>> frames = resolveClothFrames(s, mesh);
  ASSERT_TRUE(frames) << frames.error();
  ASSERT_EQ(frames->size(), 3u);
  EXPECT_EQ((*frames)[0].name, "first");
  EXPECT_EQ((*frames)[0].vertex, 0);
  EXPECT_EQ((*frames)[1].vertex, 11) << "(-1, -1): the last row's last column, 2 * 4 + 3";
  EXPECT_EQ((*frames)[2].vertex, 6) << "(1, 2): 1 * 4 + 2";
  for (const ClothFrame& f : *frames) {
    // The neighbour shares a triangle with the vertex.
    bool shared = false;
    for (const Triangle& t : mesh.triangles) {
      const bool hasV = std::count(t.begin(), t.end(), f.vertex) > 0;
      shared = shared || (hasV && std::count(t.begin(), t.end(), f.neighbour) > 0 && f.neighbour != f.vertex);
    }
    EXPECT_TRUE(shared) << f.name;
  }
}

TEST(ClothFrames, BadEntriesAreNamed) {
  const Mesh mesh = *makeGrid(scene().grid);
  auto error = [&mesh](const std::string& frames) {
    Expected<Scene> s = parseScene(YAML::Load(std::string(R"(
mesh: {type: grid, rows: 3, cols: 4, width: 0.3, height: 0.2}
material: {model: stvk, youngs_modulus: 2.0e6, poisson_ratio: 0.3}
frames: )") + frames));
    if (!s) return s.error();
    Expected<std::vector<ClothFrame>> f = resolveClothFrames(*s, mesh);
    return f ? std::string("no error") : f.error();
  };
  EXPECT_NE(error("[{name: a, vertex: 12}]").find("frames[0]: vertex 12 does not exist"), std::string::npos)
      << error("[{name: a, vertex: 12}]");
  EXPECT_NE(error("[{name: a, vertex: 0}, {name: a, vertex: 1}]").find("frames[1].name 'a' is used twice"),
            std::string::npos);
  EXPECT_NE(error("[{name: /a, vertex: 0}]").find("frames[0].name"), std::string::npos);
  EXPECT_NE(error("[{name: a, grid_vertex: [3, 0]}]").find("frames[0]: grid vertex (3, 0) is outside"),
            std::string::npos);
  EXPECT_NE(error("[{name: a}]").find("frames[0] needs one of vertex and grid_vertex"), std::string::npos);
  EXPECT_NE(error("[{name: a, vertex: 0, grid_vertex: [0, 0]}]").find("needs one of"), std::string::npos);
  EXPECT_NE(error("[{name: a, vertx: 0}]").find("unknown key 'frames[0].vertx'"), std::string::npos);
  EXPECT_NE(error("[{vertex: 0}]").find("frames[0].name is required"), std::string::npos);
}

TEST(ClothFrames, TheTangentFrameFollowsTheNormalAndAnEdge) {
  const Scene s = scene();
  const Mesh mesh = *makeGrid(s.grid);
  const ClothFrame f = resolveClothFrames(s, mesh)->at(2);
  const Eigen::Vector3d X = vertex3(mesh, mesh.restPositions, f.vertex);
  const Eigen::Vector3d edge = vertex3(mesh, mesh.restPositions, f.neighbour) - X;
  // Flat: the edge is already tangent, so x is the edge's direction; z the normal given.
  const Eigen::Isometry3d T = clothFramePose(mesh, mesh.restPositions, f, Eigen::Vector3d::UnitZ());
  EXPECT_TRUE(T.translation().isApprox(X));
  EXPECT_TRUE(T.linear().col(0).isApprox(edge.normalized()));
  EXPECT_TRUE(T.linear().col(2).isApprox(Eigen::Vector3d::UnitZ()));
  EXPECT_NEAR((T.linear() * T.linear().transpose() - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-12);
  EXPECT_NEAR(T.linear().determinant(), 1.0, 1e-12) << "right-handed";
  // A normal tilted 30 degrees about y: x is the edge with its normal component removed.
  const Eigen::Vector3d n(std::sin(M_PI / 6), 0.0, std::cos(M_PI / 6));
  const Eigen::Isometry3d U = clothFramePose(mesh, mesh.restPositions, f, n);
  const Eigen::Vector3d tangent = (edge - n.dot(edge) * n).normalized();
  EXPECT_TRUE(U.linear().col(0).isApprox(tangent));
  EXPECT_TRUE(U.linear().col(1).isApprox(n.cross(tangent)));
  // As a message: parent from the header, child the frame's name.
  std_msgs::Header h;
  h.frame_id = "world";
  const geometry_msgs::TransformStamped msg = transformMessage(h, f.name, U);
  EXPECT_EQ(msg.child_frame_id, "middle");
  EXPECT_EQ(msg.header.frame_id, "world");
  EXPECT_DOUBLE_EQ(msg.transform.translation.x, X.x());
  const Eigen::Quaterniond q(msg.transform.rotation.w, msg.transform.rotation.x,
                             msg.transform.rotation.y, msg.transform.rotation.z);
  EXPECT_TRUE(q.toRotationMatrix().isApprox(U.linear(), 1e-12));
}

TEST(ClothMarker, ATriangleListWithAColourPerVertex) {
  const Mesh mesh = *makeGrid(scene().grid);
  std::vector<Colour> colours(mesh.numVertices());
  for (Index i = 0; i < mesh.numVertices(); ++i) colours[i] = Colour(0.05f * i, 0.5f, 1.0f - 0.05f * i);
  std_msgs::Header h;
  h.frame_id = "world";
  const visualization_msgs::Marker m = clothMarker(h, mesh, mesh.restPositions, colours);
  EXPECT_EQ(m.type, visualization_msgs::Marker::TRIANGLE_LIST);
  ASSERT_EQ(m.points.size(), 3 * mesh.triangles.size());
  ASSERT_EQ(m.colors.size(), m.points.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const Index v = mesh.triangles[t][k];
      EXPECT_EQ(m.points[3 * t + k].x, mesh.restPositions[3 * v]);
      EXPECT_EQ(m.points[3 * t + k].z, mesh.restPositions[3 * v + 2]);
      EXPECT_EQ(m.colors[3 * t + k].r, colours[v].x());
      EXPECT_EQ(m.colors[3 * t + k].b, colours[v].z());
    }
  }
}

namespace {

// ~camera as roscpp reads it from the parameter server: a struct of values.
XmlRpc::XmlRpcValue cameraParams(const std::string& yaml) { return toXmlRpc(YAML::Load(yaml)); }

std::string cameraError(const std::string& yaml) {
  const Expected<CameraSettings> c = readCameraSettings(cameraParams(yaml));
  return c ? std::string("no error") : c.error();
}

}  // namespace

TEST(CameraParameters, IntrinsicsFromAFieldOfViewOrFocalLengths) {
  // 90 degrees over 200 pixels: fx = 100 / tan(45 deg) = 100.
  Expected<CameraSettings> c = readCameraSettings(cameraParams(
      "{frame_id: cam, width: 200, height: 100, horizontal_fov: 1.5707963267948966, rate: 5}"));
  ASSERT_TRUE(c) << c.error();
  EXPECT_EQ(c->frame, "cam");
  EXPECT_NEAR(c->intrinsics.fx, 100.0, 1e-9);
  EXPECT_NEAR(c->intrinsics.fy, 100.0, 1e-9);
  EXPECT_DOUBLE_EQ(c->intrinsics.cx, 99.5);
  EXPECT_DOUBLE_EQ(c->intrinsics.cy, 49.5);
  EXPECT_EQ(c->rate, 5.0);
  EXPECT_FALSE(c->pose);
  c = readCameraSettings(cameraParams("{width: 64, height: 48, fx: 50, cy: 20.5}"));
  ASSERT_TRUE(c) << c.error();
  EXPECT_EQ(c->intrinsics.fx, 50.0);
  EXPECT_EQ(c->intrinsics.fy, 50.0) << "fy defaults to fx";
  EXPECT_EQ(c->intrinsics.cx, 31.5);
  EXPECT_EQ(c->intrinsics.cy, 20.5);
  // A pose by position and look-at point: the optical z axis points from one to the other.
  c = readCameraSettings(cameraParams("{pose: {position: [0, -2, 1], look_at: [0, 0, 1]}}"));
  ASSERT_TRUE(c) << c.error();
  ASSERT_TRUE(c->pose);
  EXPECT_TRUE(c->pose->translation().isApprox(Eigen::Vector3d(0, -2, 1)));
  EXPECT_TRUE(c->pose->linear().col(2).isApprox(Eigen::Vector3d(0, 1, 0)));
  EXPECT_TRUE(c->pose->linear().col(1).isApprox(Eigen::Vector3d(0, 0, -1))) << "image down is world down";
}

TEST(CameraParameters, BadValuesAreNamed) {
  EXPECT_NE(cameraError("{widht: 640}").find("unknown parameter ~camera/widht"), std::string::npos);
  EXPECT_NE(cameraError("{width: -3}").find("~camera/width"), std::string::npos);
  EXPECT_NE(cameraError("{width: 64.5}").find("whole numbers"), std::string::npos);
  EXPECT_NE(cameraError("{fx: 100, horizontal_fov: 1.0}").find("give one of them"), std::string::npos);
  EXPECT_NE(cameraError("{horizontal_fov: 4.0}").find("below pi"), std::string::npos);
  EXPECT_NE(cameraError("{min_range: 5, max_range: 1}").find("~camera/max_range"), std::string::npos);
  EXPECT_NE(cameraError("{pose: {position: [0, 0, 1]}}").find("~camera/pose needs"), std::string::npos);
  EXPECT_NE(cameraError("{pose: {position: [0, 0, 1], look_at: [0, 0, 0]}}").find("up direction"),
            std::string::npos);
  EXPECT_NE(cameraError("{noise: {dropout: 2}}").find("dropout"), std::string::npos);
  EXPECT_NE(cameraError("{noise: {sigma: 0.1}}").find("unknown parameter ~camera/noise/sigma"),
            std::string::npos);
  EXPECT_NE(cameraError("{rate: -1}").find("~camera/rate"), std::string::npos);
}
