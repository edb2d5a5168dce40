#include "fem_cloth/ros/perception_messages.h"

#include <sensor_msgs/image_encodings.h>
#include <tf2_eigen/tf2_eigen.h>

#include <cstring>
#include <set>

namespace fem_cloth {

Expected<PointFields> parsePointFields(const std::vector<std::string>& names) {
  PointFields f;
  for (const std::string& n : names) {
    if (n == "normal") {
      f.normal = true;
    } else if (n == "strain") {
      f.strain = true;
    } else if (n == "velocity") {
      f.velocity = true;
    } else {
      return Error{"unknown point field '" + n + "' (known: normal, strain, velocity)"};
    }
  }
  return f;
}

sensor_msgs::PointCloud2 toPointCloud(const std_msgs::Header& header, const Mesh& mesh,
                                      const VectorX& x, const PointFields& fields,
                                      const std::vector<Eigen::Vector3d>& normals,
                                      const std::vector<double>& strains, const VectorX& velocities) {
  sensor_msgs::PointCloud2 cloud;
  cloud.header = header;
  std::vector<std::string> names = {"x", "y", "z"};
  if (fields.normal) names.insert(names.end(), {"normal_x", "normal_y", "normal_z"});
  if (fields.strain) names.push_back("strain");
  if (fields.velocity) names.insert(names.end(), {"vx", "vy", "vz"});
  for (std::size_t k = 0; k < names.size(); ++k) {
    sensor_msgs::PointField f;
    f.name = names[k];
    f.offset = static_cast<std::uint32_t>(4 * k);
    f.datatype = sensor_msgs::PointField::FLOAT32;
    f.count = 1;
    cloud.fields.push_back(f);
  }
  const std::size_t n = static_cast<std::size_t>(mesh.numVertices());
  cloud.height = 1;
  cloud.width = static_cast<std::uint32_t>(n);
  cloud.is_bigendian = false;
  cloud.point_step = static_cast<std::uint32_t>(4 * names.size());
  cloud.row_step = cloud.point_step * cloud.width;
  cloud.is_dense = true;
  cloud.data.resize(cloud.row_step);
  std::vector<float> point(names.size());
  for (std::size_t i = 0; i < n; ++i) {
    std::size_t k = 0;
    auto put = [&point, &k](const Eigen::Vector3d& v) {
      for (int a = 0; a < 3; ++a) point[k++] = static_cast<float>(v[a]);
    };
    put(vertex3(mesh, x, static_cast<Index>(i)));
    if (fields.normal) put(normals[i]);
    if (fields.strain) point[k++] = static_cast<float>(strains[i]);
    if (fields.velocity) put(vertex3(mesh, velocities, static_cast<Index>(i)));
    // x86 and ARM are little-endian, as is_bigendian = false says.
    std::memcpy(&cloud.data[i * cloud.point_step], point.data(), cloud.point_step);
  }
  return cloud;
}

namespace {

// An image of the camera's size, `bytes` per pixel, rows packed, its data copied from `data`.
sensor_msgs::Image imageMessage(const std_msgs::Header& header, const CameraIntrinsics& camera,
                                const std::string& encoding, std::uint32_t bytes, const void* data) {
  sensor_msgs::Image image;
  image.header = header;
  image.width = static_cast<std::uint32_t>(camera.width);
  image.height = static_cast<std::uint32_t>(camera.height);
  image.encoding = encoding;
  image.is_bigendian = false;  // x86 and ARM: the floats of 32FC1 are little-endian
  image.step = bytes * image.width;
  image.data.resize(static_cast<std::size_t>(image.step) * image.height);
  std::memcpy(image.data.data(), data, image.data.size());
  return image;
}

}  // namespace

sensor_msgs::Image depthImageMessage(const std_msgs::Header& header, const CameraIntrinsics& camera,
                                     const std::vector<float>& depth) {
  return imageMessage(header, camera, sensor_msgs::image_encodings::TYPE_32FC1, 4, depth.data());
}

sensor_msgs::Image colorImageMessage(const std_msgs::Header& header, const CameraIntrinsics& camera,
                                     const std::vector<std::uint8_t>& rgb) {
  return imageMessage(header, camera, sensor_msgs::image_encodings::RGB8, 3, rgb.data());
}

sensor_msgs::CameraInfo cameraInfoMessage(const std_msgs::Header& header, const CameraIntrinsics& camera) {
  sensor_msgs::CameraInfo info;
  info.header = header;
  info.width = static_cast<std::uint32_t>(camera.width);
  info.height = static_cast<std::uint32_t>(camera.height);
  info.distortion_model = "plumb_bob";
  info.D.assign(5, 0.0);
  info.K = {camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0};
  info.R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
  info.P = {camera.fx, 0.0, camera.cx, 0.0, 0.0, camera.fy, camera.cy, 0.0, 0.0, 0.0, 1.0, 0.0};
  return info;
}

Expected<std::vector<ClothFrame>> resolveClothFrames(const Scene& scene, const Mesh& mesh) {
  std::vector<ClothFrame> out;
  std::set<std::string> names;
  for (std::size_t k = 0; k < scene.frames.size(); ++k) {
    const SceneFrame& f = scene.frames[k];
    const std::string key = "frames[" + std::to_string(k) + "]";
    if (f.name.empty() || f.name[0] == '/' || f.name.find_first_of(" \t\n") != std::string::npos) {
      return Error{key + ".name must be a tf frame id (not empty, no leading '/', no spaces), got '" +
                   f.name + "'"};
    }
    if (!names.insert(f.name).second) return Error{key + ".name '" + f.name + "' is used twice"};
    Expected<std::vector<Index>> v = resolveSelection(f.select, scene, mesh.numVertices(), key);
    if (!v) return Error{v.error()};
    ClothFrame frame{f.name, v->front(), -1};
    for (const Triangle& t : mesh.triangles) {
      for (int c = 0; c < 3 && frame.neighbour < 0; ++c) {
        if (t[c] == frame.vertex) frame.neighbour = t[(c + 1) % 3];
      }
      if (frame.neighbour >= 0) break;
    }
    if (frame.neighbour < 0) {
      return Error{key + ": vertex " + std::to_string(frame.vertex) + " is in no triangle"};
    }
    out.push_back(frame);
  }
  return out;
}

Eigen::Isometry3d clothFramePose(const Mesh& mesh, const VectorX& x, const ClothFrame& frame,
                                 const Eigen::Vector3d& normal) {
  const Eigen::Vector3d origin = vertex3(mesh, x, frame.vertex);
  const Eigen::Vector3d edge = vertex3(mesh, x, frame.neighbour) - origin;
  Eigen::Vector3d ex = edge - normal.dot(edge) * normal;
  if (!(ex.norm() > 1e-12 * (edge.norm() + 1e-300))) {
    // The edge stands along the normal (a collapsed neighbourhood): any tangent will do.
    ex = normal.unitOrthogonal();
  }
  ex.normalize();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear().col(0) = ex;
  pose.linear().col(1) = normal.cross(ex);
  pose.linear().col(2) = normal;
  pose.translation() = origin;
  return pose;
}

geometry_msgs::TransformStamped transformMessage(const std_msgs::Header& header,
                                                 const std::string& child,
                                                 const Eigen::Isometry3d& pose) {
  geometry_msgs::TransformStamped t = tf2::eigenToTransform(pose);
  t.header = header;
  t.child_frame_id = child;
  return t;
}

visualization_msgs::Marker clothMarker(const std_msgs::Header& header, const Mesh& mesh,
                                       const VectorX& x, const std::vector<Colour>& vertexColours) {
  visualization_msgs::Marker m;
  m.header = header;
  m.ns = "cloth";
  m.id = 0;
  m.type = visualization_msgs::Marker::TRIANGLE_LIST;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.scale.x = m.scale.y = m.scale.z = 1.0;
  m.color.a = 1.0f;
  m.points.resize(3 * mesh.triangles.size());
  m.colors.resize(3 * mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const Index v = mesh.triangles[t][k];
      m.points[3 * t + k] = tf2::toMsg(vertex3(mesh, x, v));
      std_msgs::ColorRGBA& c = m.colors[3 * t + k];
      c.r = vertexColours[v].x();
      c.g = vertexColours[v].y();
      c.b = vertexColours[v].z();
      c.a = 1.0f;
    }
  }
  return m;
}

}  // namespace fem_cloth
