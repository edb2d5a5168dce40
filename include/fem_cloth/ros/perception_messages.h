// What the perception outputs of the node put into messages, as free functions (msg builders
// in the manner of grid_map_ros's converters): the cloth as a point cloud, camera images and
// their CameraInfo, tf frames of cloth points, the shaded cloth marker. No master needed.
#pragma once

#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/Header.h>
#include <visualization_msgs/Marker.h>

#include <string>
#include <vector>

#include "fem_cloth/core/scene.h"
#include "fem_cloth/render/camera.h"
#include "fem_cloth/render/colour.h"

namespace fem_cloth {

// --- Point cloud -----------------------------------------------------------------------------

/// Optional fields of ~points beside x, y, z.
struct PointFields {
  bool normal = false;    ///< normal_x, normal_y, normal_z: the unit vertex normal (PCL's names)
  bool strain = false;    ///< strain: the area-weighted vertex strain (s1 - 1)
  bool velocity = false;  ///< vx, vy, vz: the vertex velocity (m/s)
};

/// From names "normal", "strain", "velocity" (any order); an unknown name is an error naming it.
Expected<PointFields> parsePointFields(const std::vector<std::string>& names);

/// The cloth's vertices as an unorganised cloud: height 1, width = number of vertices, point k
/// is vertex k; float32 little-endian fields x y z, then those chosen, packed in that order;
/// dense (every value finite). normals, strains and velocities (d per vertex) are read only
/// for the fields chosen.
sensor_msgs::PointCloud2 toPointCloud(const std_msgs::Header& header, const Mesh& mesh,
                                      const VectorX& x, const PointFields& fields,
                                      const std::vector<Eigen::Vector3d>& normals,
                                      const std::vector<double>& strains, const VectorX& velocities);

// --- Camera ----------------------------------------------------------------------------------

/// 32FC1, metres along the optical axis, NaN where nothing is seen (REP-118); row-major.
sensor_msgs::Image depthImageMessage(const std_msgs::Header& header, const CameraIntrinsics& camera,
                                     const std::vector<float>& depth);
/// rgb8, row-major.
sensor_msgs::Image colorImageMessage(const std_msgs::Header& header, const CameraIntrinsics& camera,
                                     const std::vector<std::uint8_t>& rgb);
/// plumb_bob without distortion; K from the intrinsics, R = I, P = [K | 0] (a monocular camera).
sensor_msgs::CameraInfo cameraInfoMessage(const std_msgs::Header& header, const CameraIntrinsics& camera);

// --- tf frames of cloth points ---------------------------------------------------------------

/// A scene frame (scene.h, SceneFrame) resolved against the mesh: its vertex and the neighbour
/// that gives the frame's x direction (the next vertex of the first triangle that has it).
struct ClothFrame {
  std::string name;
  Index vertex = 0;
  Index neighbour = 0;
};

/// Resolves the scene's frames; errors name the entry (frames[k]): a vertex that does not exist
/// or is in no triangle, a name that is empty, starts with '/' or appears twice.
Expected<std::vector<ClothFrame>> resolveClothFrames(const Scene& scene, const Mesh& mesh);

/// The local tangent frame at the frame's vertex: origin at the vertex, z along its unit normal,
/// x along the edge to the neighbour projected onto the tangent plane, y = z x x.
Eigen::Isometry3d clothFramePose(const Mesh& mesh, const VectorX& x, const ClothFrame& frame,
                                 const Eigen::Vector3d& normal);

/// header.frame_id is the parent; child the frame's name.
geometry_msgs::TransformStamped transformMessage(const std_msgs::Header& header,
                                                 const std::string& child,
                                                 const Eigen::Isometry3d& pose);

// --- Marker ----------------------------------------------------------------------------------

/// The cloth as an RViz triangle list with a colour per vertex (namespace "cloth", id 0): RViz
/// draws such a list without its own lighting, so the shading baked into the colours is what
/// shows, smooth across triangles.
visualization_msgs::Marker clothMarker(const std_msgs::Header& header, const Mesh& mesh,
                                       const VectorX& x, const std::vector<Colour>& vertexColours);

}  // namespace fem_cloth
