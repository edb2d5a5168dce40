// The node's perception outputs (docs/perception.md): the cloth as a point cloud (~points), a
// simulated depth and colour camera (~camera/...), tf frames (the simulation frame when nobody
// else publishes it, named cloth points, the camera when its pose is a parameter) and the
// shaded cloth marker (~marker). Each is computed only when someone subscribes (tf frames
// always: tf has no subscriber count), from the driver's state after a step.
//
// Private parameters (listed by perceptionParameterNames(); defaults in docs/node.md):
//   point_fields        list or string   optional ~points fields: normal, strain, velocity
//   color_by_strain     bool             colour the cloth by strain instead of cloth_color
//   cloth_color         [r, g, b]        the fabric's colour, components in [0, 1]
//   light_direction     [x, y, z]        towards the light, in the simulation frame
//   strain_color_max    double           strain shown fully red
//   publish_world_frame auto|true|false  broadcast the simulation frame (see PerceptionOutputs)
//   camera              map              the simulated camera (readCameraSettings); none if unset
#pragma once

#include <ros/ros.h>
#include <tf2/buffer_core.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fem_cloth/render/depth_noise.h"
#include "fem_cloth/render/scene_view.h"
#include "fem_cloth/ros/perception_messages.h"
#include "fem_cloth/ros/simulation_driver.h"

namespace fem_cloth {

enum class WorldFramePolicy { Auto, Always, Never };

struct CameraSettings {
  std::string frame = "fem_cloth_camera";  ///< its optical frame (z forward, x right, y down)
  /// Where the camera is in the simulation frame, when given as a parameter: the node then
  /// broadcasts `frame` itself (static). Otherwise tf must know `frame`.
  std::optional<Eigen::Isometry3d> pose;
  CameraIntrinsics intrinsics;
  double minRange = 0.05, maxRange = 10.0;  ///< m, along the optical axis
  double rate = 10.0;                       ///< Hz of simulation time
  DepthNoise noise;
};

struct PerceptionSettings {
  std::string frame = "world";  ///< the simulation frame
  /// The child of the identity transform that stands for the simulation frame in tf.
  std::string originFrame = "fem_cloth_node";
  bool alwaysPublish = false;
  /// Broadcast the scene's cloth frames: not while replaying a recording, whose /tf plays them
  /// back with the same stamps (tf would see each transform twice).
  bool clothFrames = true;
  PointFields pointFields;
  ClothLook look;
  ViewStyle style;
  WorldFramePolicy worldFrame = WorldFramePolicy::Auto;
  std::optional<CameraSettings> camera;
};

/// The private parameters read by readPerceptionParameters.
const std::vector<std::string>& perceptionParameterNames();

/// Reads them into `settings` (frame, originFrame, alwaysPublish, clothFrames are the caller's); on a bad
/// value returns false with `error` naming the parameter.
bool readPerceptionParameters(const ros::NodeHandle& privateNode, PerceptionSettings& settings,
                              std::string* error);

/// ~camera as a parameter map (keys in docs/node.md); an unknown key is an error.
Expected<CameraSettings> readCameraSettings(const XmlRpc::XmlRpcValue& camera);

class PerceptionOutputs {
 public:
  /// Resolves the scene's frames (errors name the entry), advertises the topics and broadcasts
  /// the static frames (camera pose; the simulation frame with publish_world_frame: true).
  static Expected<std::unique_ptr<PerceptionOutputs>> create(ros::NodeHandle privateNode,
                                                             const SimulationDriver& driver,
                                                             const Scene& scene,
                                                             const tf2::BufferCore& tf,
                                                             PerceptionSettings settings);

  /// After a step, a reset or a resume, with the caller holding the driver: stateDue at the
  /// node's publish rate (~points, cloth frames), markerDue at its marker rate (~marker). The
  /// camera renders at its own rate of simulation time.
  void publish(bool stateDue, bool markerDue);

 private:
  PerceptionOutputs(ros::NodeHandle privateNode, const SimulationDriver& driver,
                    const tf2::BufferCore& tf, PerceptionSettings settings,
                    std::vector<ClothFrame> frames);
  bool wanted(const ros::Publisher& pub) const {
    return settings_.alwaysPublish || pub.getNumSubscribers() > 0;
  }
  /// In auto mode, a second (wall time) after start: the identity transform to originFrame
  /// unless tf knows the simulation frame by then (from another node, or from the camera or
  /// cloth frames this node broadcasts: RViz finds it either way).
  void decideWorldFrame();
  void publishWorldFrame();
  void publishClothFrames();
  void publishCamera();
  bool cameraWanted() const;
  std::optional<Eigen::Isometry3d> cameraPose(const ros::Time& stamp);
  const std::vector<Eigen::Vector3d>& normals();
  const std::vector<Colour>& colours();
  std::vector<PlacedShape> obstacles() const;
  std_msgs::Header header() const;

  ros::NodeHandle private_;
  const SimulationDriver& driver_;
  const tf2::BufferCore& tf_;
  PerceptionSettings settings_;
  std::vector<ClothFrame> frames_;
  ros::Publisher pointsPub_, markerPub_, depthPub_, colorPub_, depthInfoPub_, colorInfoPub_;
  tf2_ros::TransformBroadcaster broadcaster_;
  tf2_ros::StaticTransformBroadcaster staticBroadcaster_;
  std::optional<SceneView> view_;
  ros::WallTimer worldFrameTimer_;
  ros::Time lastFrameStamp_;
  std::optional<double> lastCameraTime_;  // simulation time of the last rendered frame
  // Per publish(): computed on first use.
  bool normalsReady_ = false, coloursReady_ = false;
  std::vector<Eigen::Vector3d> normals_;
  std::vector<Colour> colours_;
};

}  // namespace fem_cloth
