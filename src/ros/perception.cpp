#include "fem_cloth/ros/perception.h"

#include <tf2/exceptions.h>
#include <tf2_eigen/tf2_eigen.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "fem_cloth/core/metrics.h"
#include "fem_cloth/ros/scene_params.h"
#include "fem_cloth/ros/transform_wait.h"

namespace fem_cloth {

namespace {

using Value = XmlRpc::XmlRpcValue;

bool toDouble(const Value& v, double& out) {
  Value copy = v;  // XmlRpcValue's conversions are not const
  if (copy.getType() == Value::TypeDouble) {
    out = static_cast<double>(copy);
  } else if (copy.getType() == Value::TypeInt) {
    out = static_cast<int>(copy);
  } else {
    return false;
  }
  return std::isfinite(out);
}

bool toVector3(const Value& v, Eigen::Vector3d& out) {
  Value copy = v;
  if (copy.getType() != Value::TypeArray || copy.size() != 3) return false;
  for (int k = 0; k < 3; ++k) {
    if (!toDouble(copy[k], out[k])) return false;
  }
  return true;
}

// The keys of a parameter map, each checked against `known`.
Status checkKeys(const Value& map, const std::string& where, const std::vector<std::string>& known) {
  Value copy = map;
  if (copy.getType() != Value::TypeStruct) return Error{"parameter ~" + where + " must be a map"};
  for (auto it = copy.begin(); it != copy.end(); ++it) {
    if (std::find(known.begin(), known.end(), it->first) == known.end()) {
      std::string list;
      for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
      return Error{"unknown parameter ~" + where + "/" + it->first + " (known: " + list + ")"};
    }
  }
  return Status::success();
}

// Reads map[key] into out when present: a number (positive if `positive`), or an error naming
// ~where/key.
Status readNumber(const Value& map, const std::string& where, const std::string& key, double& out,
                  bool positive) {
  Value copy = map;
  if (!copy.hasMember(key)) return Status::success();
  if (!toDouble(copy[key], out) || (positive && !(out > 0.0))) {
    return Error{"parameter ~" + where + "/" + key + " must be a " +
                 (positive ? "positive " : "") + "number"};
  }
  return Status::success();
}

Status readPose(const Value& pose, Eigen::Isometry3d& out) {
  if (Status s = checkKeys(pose, "camera/pose", {"position", "look_at", "up"}); !s) return s;
  Value copy = pose;
  Eigen::Vector3d eye, target, up = Eigen::Vector3d::UnitZ();
  if (!copy.hasMember("position") || !toVector3(copy["position"], eye) ||
      !copy.hasMember("look_at") || !toVector3(copy["look_at"], target) ||
      (copy.hasMember("up") && !toVector3(copy["up"], up))) {
    return Error{"parameter ~camera/pose needs position: [x, y, z] and look_at: [x, y, z] (m, "
                 "simulation frame), and optionally up: [x, y, z]"};
  }
  Expected<Eigen::Isometry3d> p = lookAt(eye, target, up);
  if (!p) return Error{"parameter ~camera/pose: " + p.error()};
  out = *p;
  return Status::success();
}

Status readNoise(const Value& noise, DepthNoise& out) {
  if (Status s = checkKeys(noise, "camera/noise", {"a", "b", "dropout", "seed"}); !s) return s;
  for (auto [key, value] : {std::pair<const char*, double*>{"a", &out.a}, {"b", &out.b},
                            {"dropout", &out.dropout}}) {
    if (Status s = readNumber(noise, "camera/noise", key, *value, false); !s) return s;
  }
  double seed = 0.0;
  if (Status s = readNumber(noise, "camera/noise", "seed", seed, false); !s) return s;
  if (seed < 0 || seed != std::floor(seed) || seed > 9.0e15) {
    return Error{"parameter ~camera/noise/seed must be a whole number >= 0"};
  }
  out.seed = static_cast<std::uint64_t>(seed);
  if (Status s = out.validate(); !s) return Error{"parameter ~camera/noise: " + s.error()};
  return Status::success();
}

Status readIntrinsics(const Value& camera, CameraIntrinsics& k) {
  Value copy = camera;
  double width = k.width, height = k.height, fov = 0.0;
  if (Status s = readNumber(camera, "camera", "width", width, true); !s) return s;
  if (Status s = readNumber(camera, "camera", "height", height, true); !s) return s;
  if (width != std::floor(width) || height != std::floor(height)) {
    return Error{"parameters ~camera/width and ~camera/height must be whole numbers of pixels"};
  }
  if (copy.hasMember("horizontal_fov") && copy.hasMember("fx")) {
    return Error{"parameters ~camera/horizontal_fov and ~camera/fx: give one of them"};
  }
  if (Status s = readNumber(camera, "camera", "horizontal_fov", fov, true); !s) return s;
  if (fov >= M_PI) return Error{"parameter ~camera/horizontal_fov must be below pi rad"};
  // The default is a 60 degree view; a given fx sets fy too unless fy is given.
  k = CameraIntrinsics::fromHorizontalFov(static_cast<int>(width), static_cast<int>(height),
                                          fov > 0.0 ? fov : M_PI / 3.0);
  if (Status s = readNumber(camera, "camera", "fx", k.fx, true); !s) return s;
  k.fy = k.fx;
  for (auto [key, value] : {std::pair<const char*, double*>{"fy", &k.fy}, {"cx", &k.cx}, {"cy", &k.cy}}) {
    if (Status s = readNumber(camera, "camera", key, *value, std::string(key) == "fy"); !s) return s;
  }
  if (Status s = k.validate(); !s) return Error{"parameters ~camera: " + s.error()};
  return Status::success();
}

}  // namespace

Expected<CameraSettings> readCameraSettings(const XmlRpc::XmlRpcValue& camera) {
  if (Status s = checkKeys(camera, "camera",
                           {"frame_id", "pose", "width", "height", "fx", "fy", "cx", "cy",
                            "horizontal_fov", "min_range", "max_range", "rate", "noise"});
      !s) {
    return Error{s.error()};
  }
  Value copy = camera;
  CameraSettings c;
  if (copy.hasMember("frame_id")) {
    if (copy["frame_id"].getType() != Value::TypeString) return Error{"parameter ~camera/frame_id must be a frame name"};
    c.frame = static_cast<std::string>(copy["frame_id"]);
    if (Status s = frameNameProblem(c.frame, "~camera/frame_id"); !s) return Error{s.error()};
    if (c.frame[0] == '/') c.frame.erase(0, 1);  // tf2 names frames without it
  }
  if (copy.hasMember("pose")) {
    Eigen::Isometry3d pose;
    if (Status s = readPose(copy["pose"], pose); !s) return Error{s.error()};
    c.pose = pose;
  }
  if (Status s = readIntrinsics(camera, c.intrinsics); !s) return Error{s.error()};
  if (Status s = readNumber(camera, "camera", "min_range", c.minRange, true); !s) return Error{s.error()};
  if (Status s = readNumber(camera, "camera", "max_range", c.maxRange, true); !s) return Error{s.error()};
  if (!(c.maxRange > c.minRange)) {
    return Error{"parameter ~camera/max_range must be greater than ~camera/min_range"};
  }
  c.rate = 10.0;
  if (Status s = readNumber(camera, "camera", "rate", c.rate, false); !s || c.rate < 0.0) {
    return Error{"parameter ~camera/rate must be a number >= 0 (Hz; 0: every step)"};
  }
  if (copy.hasMember("noise")) {
    if (Status s = readNoise(copy["noise"], c.noise); !s) return Error{s.error()};
  }
  return c;
}

const std::vector<std::string>& perceptionParameterNames() {
  static const std::vector<std::string> names = {"point_fields",     "color_by_strain",
                                                 "cloth_color",      "light_direction",
                                                 "strain_color_max", "publish_world_frame",
                                                 "camera"};
  return names;
}

namespace {

bool readColour(const ros::NodeHandle& nh, const std::string& name, Colour& out, std::string* error) {
  std::vector<double> v;
  if (!nh.hasParam(name)) return true;
  if (!nh.getParam(name, v) || v.size() != 3 ||
      std::any_of(v.begin(), v.end(), [](double c) { return !(c >= 0.0 && c <= 1.0); })) {
    *error = "parameter ~" + name + " must be [r, g, b] with components in [0, 1]";
    return false;
  }
  out = Colour(static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2]));
  return true;
}

bool readPointFields(const ros::NodeHandle& nh, PointFields& out, std::string* error) {
  if (!nh.hasParam("point_fields")) return true;
  std::vector<std::string> names;
  std::string text;
  if (nh.getParam("point_fields", text)) {
    std::replace(text.begin(), text.end(), ',', ' ');
    std::istringstream words(text);
    for (std::string w; words >> w;) names.push_back(w);
  } else if (!nh.getParam("point_fields", names)) {
    *error = "parameter ~point_fields must be a list of field names (normal, strain, velocity)";
    return false;
  }
  Expected<PointFields> f = parsePointFields(names);
  if (!f) {
    *error = "parameter ~point_fields: " + f.error();
    return false;
  }
  out = *f;
  return true;
}

bool readWorldFramePolicy(const ros::NodeHandle& nh, WorldFramePolicy& out, std::string* error) {
  Value v;
  if (!nh.getParam("publish_world_frame", v)) return true;
  std::string word;
  if (v.getType() == Value::TypeBoolean) {
    word = static_cast<bool>(v) ? "true" : "false";
  } else if (v.getType() == Value::TypeString) {
    word = static_cast<std::string>(v);
  }
  if (word == "auto") {
    out = WorldFramePolicy::Auto;
  } else if (word == "true") {
    out = WorldFramePolicy::Always;
  } else if (word == "false") {
    out = WorldFramePolicy::Never;
  } else {
    *error = "parameter ~publish_world_frame must be auto, true or false";
    return false;
  }
  return true;
}

}  // namespace

bool readPerceptionParameters(const ros::NodeHandle& nh, PerceptionSettings& s, std::string* error) {
  std::vector<double> light;
  if (!readPointFields(nh, s.pointFields, error) ||
      !readParam(nh, "color_by_strain", s.look.byStrain, error, "true or false") ||
      !readColour(nh, "cloth_color", s.look.colour, error) ||
      !readParam(nh, "strain_color_max", s.look.strainColourMax, error, "a number") ||
      !readParam(nh, "light_direction", light, error, "[x, y, z]") ||
      !readWorldFramePolicy(nh, s.worldFrame, error)) {
    return false;
  }
  if (!(s.look.strainColourMax > 0.0)) {
    *error = "parameter ~strain_color_max must be positive";
    return false;
  }
  if (nh.hasParam("light_direction")) {
    const Eigen::Vector3d l = light.size() == 3 ? Eigen::Vector3d(light[0], light[1], light[2])
                                                : Eigen::Vector3d::Zero();
    if (!l.allFinite() || !(l.norm() > 0.0)) {
      *error = "parameter ~light_direction must be a non-zero [x, y, z]";
      return false;
    }
    s.look.light.direction = l;
  }
  s.style.light = s.look.light;
  Value camera;
  if (nh.getParam("camera", camera)) {
    Expected<CameraSettings> c = readCameraSettings(camera);
    if (!c) {
      *error = c.error();
      return false;
    }
    s.camera = *c;
  }
  return true;
}

Expected<std::unique_ptr<PerceptionOutputs>> PerceptionOutputs::create(ros::NodeHandle privateNode,
                                                                      const SimulationDriver& driver,
                                                                      const Scene& scene,
                                                                      const tf2::BufferCore& tf,
                                                                      PerceptionSettings settings) {
  Expected<std::vector<ClothFrame>> frames =
      resolveClothFrames(scene, driver.simulator().model().mesh());
  if (!frames) return Error{"scene " + frames.error()};
  // The camera's pose goes out as the transform simulation frame -> camera frame: the same frame
  // at both ends would be a transform of a frame to itself, which tf refuses.
  if (settings.camera && tfFrameName(settings.camera->frame) == tfFrameName(settings.frame)) {
    return Error{"parameter ~camera/frame_id is '" + settings.camera->frame +
                 "', the simulation frame (~frame_id): the camera needs a frame of its own, placed by ~camera/pose "
                 "or by tf"};
  }
  return std::unique_ptr<PerceptionOutputs>(
      new PerceptionOutputs(privateNode, driver, tf, std::move(settings), std::move(frames).value()));
}

PerceptionOutputs::PerceptionOutputs(ros::NodeHandle privateNode, const SimulationDriver& driver,
                                     const tf2::BufferCore& tf, PerceptionSettings settings,
                                     std::vector<ClothFrame> frames)
    : private_(privateNode), driver_(driver), tf_(tf), settings_(std::move(settings)),
      frames_(std::move(frames)) {
  if (!settings_.frame.empty() && settings_.frame[0] == '/') settings_.frame.erase(0, 1);
  pointsPub_ = private_.advertise<sensor_msgs::PointCloud2>("points", 2);
  markerPub_ = private_.advertise<visualization_msgs::Marker>("marker", 2);
  if (settings_.camera) {
    const CameraSettings& c = *settings_.camera;
    depthPub_ = private_.advertise<sensor_msgs::Image>("camera/depth/image", 2);
    colorPub_ = private_.advertise<sensor_msgs::Image>("camera/color/image", 2);
    depthInfoPub_ = private_.advertise<sensor_msgs::CameraInfo>("camera/depth/camera_info", 2);
    colorInfoPub_ = private_.advertise<sensor_msgs::CameraInfo>("camera/color/camera_info", 2);
    view_.emplace(c.intrinsics, c.minRange, c.maxRange);
    if (c.pose) {
      std_msgs::Header h;
      h.frame_id = settings_.frame;
      staticBroadcaster_.sendTransform(transformMessage(h, c.frame, *c.pose));
    }
  }
  if (settings_.worldFrame == WorldFramePolicy::Always) publishWorldFrame();
  if (settings_.worldFrame == WorldFramePolicy::Auto) {
    // Once, a second after start (paused or not): time for other publishers' transforms to
    // reach our listener. The callback runs on the node's spinner; it only reads tf and
    // broadcasts.
    worldFrameTimer_ = private_.createWallTimer(
        ros::WallDuration(1.0), [this](const ros::WallTimerEvent&) { decideWorldFrame(); }, true);
  }
}

std_msgs::Header PerceptionOutputs::header() const {
  std_msgs::Header h;
  h.stamp = driver_.now();
  h.frame_id = settings_.frame;
  return h;
}

void PerceptionOutputs::publishWorldFrame() {
  std_msgs::Header h;
  h.frame_id = settings_.frame;
  staticBroadcaster_.sendTransform(transformMessage(h, settings_.originFrame, Eigen::Isometry3d::Identity()));
}

void PerceptionOutputs::decideWorldFrame() {
  if (!tf_._frameExists(settings_.frame)) {
    ROS_INFO_STREAM("fem_cloth_node: nothing publishes the simulation frame '" << settings_.frame
                    << "' in tf: publishing it (identity to '" << settings_.originFrame << "')");
    publishWorldFrame();
  }
}

const std::vector<Eigen::Vector3d>& PerceptionOutputs::normals() {
  if (!normalsReady_) {
    vertexNormals(driver_.simulator().model().mesh(), driver_.simulator().state().x, normals_);
    normalsReady_ = true;
  }
  return normals_;
}

const std::vector<Colour>& PerceptionOutputs::colours() {
  if (!coloursReady_) {
    const Model& model = driver_.simulator().model();
    clothVertexColours(model.mesh(), model.rest(), driver_.simulator().state().x, normals(),
                       settings_.look, colours_);
    coloursReady_ = true;
  }
  return colours_;
}

void PerceptionOutputs::publish(bool stateDue, bool markerDue) {
  normalsReady_ = coloursReady_ = false;
  const Model& model = driver_.simulator().model();
  const VectorX& x = driver_.simulator().state().x;
  if (stateDue) {
    publishClothFrames();
    if (wanted(pointsPub_)) {
      std::vector<double> strains;
      if (settings_.pointFields.strain) {
        std::vector<double> perTriangle;
        triangleStrains(model.mesh(), model.rest(), x, perTriangle);
        vertexAverages(model.mesh(), x, perTriangle, strains);
      }
      static const std::vector<Eigen::Vector3d> none;
      pointsPub_.publish(toPointCloud(header(), model.mesh(), x, settings_.pointFields,
                                      settings_.pointFields.normal ? normals() : none, strains,
                                      driver_.simulator().state().v));
    }
  }
  if (markerDue && wanted(markerPub_)) markerPub_.publish(clothMarker(header(), model.mesh(), x, colours()));
  if (settings_.camera && cameraWanted()) {
    const double t = driver_.simulator().time();
    const double period = settings_.camera->rate > 0.0 ? 1.0 / settings_.camera->rate : 0.0;
    const double halfStep = 0.5 * driver_.simulator().settings().dt;
    // Due a period after the last frame; a reset (time going back) restarts the schedule.
    if (!lastCameraTime_ || t < *lastCameraTime_ || t - *lastCameraTime_ >= period - halfStep) {
      lastCameraTime_ = t;
      publishCamera();
    }
  }
}

void PerceptionOutputs::publishClothFrames() {
  if (frames_.empty() || !settings_.clothFrames) return;
  const std_msgs::Header h = header();
  if (h.stamp == lastFrameStamp_) return;  // the same state again (a resume): tf would warn
  lastFrameStamp_ = h.stamp;
  const Mesh& mesh = driver_.simulator().model().mesh();
  const VectorX& x = driver_.simulator().state().x;
  std::vector<geometry_msgs::TransformStamped> transforms;
  for (const ClothFrame& f : frames_) {
    transforms.push_back(transformMessage(h, f.name, clothFramePose(mesh, x, f, normals()[f.vertex])));
  }
  broadcaster_.sendTransform(transforms);
}

bool PerceptionOutputs::cameraWanted() const {
  return wanted(depthPub_) || wanted(colorPub_) || wanted(depthInfoPub_) || wanted(colorInfoPub_);
}

std::optional<Eigen::Isometry3d> PerceptionOutputs::cameraPose(const ros::Time& stamp) {
  const CameraSettings& c = *settings_.camera;
  if (c.pose) return c.pose;
  // The camera's pose when the state was reached; a camera frame whose transform has not
  // arrived for that time yet is drawn from its newest one.
  for (const ros::Time& at : {stamp, ros::Time(0)}) {
    try {
      return tf2::transformToEigen(tf_.lookupTransform(settings_.frame, c.frame, at));
    } catch (const tf2::TransformException& e) {
      if (!at.isZero()) continue;
      ROS_WARN_STREAM_THROTTLE(5.0, "fem_cloth_node: no camera image: the camera frame '"
                                        << c.frame << "' is not known in '" << settings_.frame
                                        << "' (" << e.what() << ")");
    }
  }
  return std::nullopt;
}

std::vector<PlacedShape> PerceptionOutputs::obstacles() const {
  std::vector<PlacedShape> out;
  if (const ObstacleSet* obstacles = driver_.simulator().obstacles()) {
    for (std::size_t k = 0; k < obstacles->size(); ++k) {
      out.push_back({(*obstacles)[k].shape, obstacles->shapePose(k)});
    }
  }
  return out;
}

void PerceptionOutputs::publishCamera() {
  const CameraSettings& c = *settings_.camera;
  std_msgs::Header h = header();
  const std::optional<Eigen::Isometry3d> pose = cameraPose(h.stamp);
  if (!pose) return;
  h.frame_id = c.frame;
  const Model& model = driver_.simulator().model();
  view_->render(*pose, model.mesh(), driver_.simulator().state().x, colours(), obstacles(), settings_.style);
  if (wanted(depthPub_)) {
    // The noise of step k is the same in a replay of the run.
    std::vector<float> depth = view_->image().depth();
    applyDepthNoise(depth, c.noise, driver_.stepIndex());
    depthPub_.publish(depthImageMessage(h, c.intrinsics, depth));
  }
  if (wanted(colorPub_)) colorPub_.publish(colorImageMessage(h, c.intrinsics, view_->image().rgb()));
  const sensor_msgs::CameraInfo info = cameraInfoMessage(h, c.intrinsics);
  if (wanted(depthInfoPub_)) depthInfoPub_.publish(info);
  if (wanted(colorInfoPub_)) colorInfoPub_.publish(info);
}

}  // namespace fem_cloth
