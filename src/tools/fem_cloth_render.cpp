// fem_cloth_render: renders a recorded run (a bag of fem_cloth_node or fem_cloth_sim) to PNG
// frames, with the renderer of the node's simulated camera (src/render/): the shaded cloth and
// the scene's obstacles at their poses of the time (scripted motion, or tf frames from the bag).
// No ROS master needed. scripts/render turns the frames into an MP4.
//
//   fem_cloth_render BAG --out DIR [--view config/views/NAME.yaml] [--fps 30] [--width W]
//                    [--height H] [--depth] [--color-by-strain] [--node /fem_cloth_node]
//
// The camera: `camera:` of a view file (docs/perception.md; its pose, size and field of view),
// or, without one, a camera that frames the cloth's first and last states. Writes
// DIR/frame_00000.png ... (and with --depth DIR/depth_00000.png, 16-bit millimetres, 0 where
// nothing is seen); prints a progress bar on stderr. Exit status 2 for a bad bag or option.
#include <CLI/CLI.hpp>
#include <png.h>
#include <rosbag/view.h>
#include <tf2/exceptions.h>
#include <tf2_eigen/tf2_eigen.h>

#include <ctime>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>

#include "fem_cloth/ClothState.h"
#include "fem_cloth/io/command_line.h"
#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/ros/bag_io.h"
#include "fem_cloth/ros/perception.h"
#include "fem_cloth/ros/scene_params.h"

using namespace fem_cloth;

namespace {

struct Options {
  std::string bag, out, view, node = "/fem_cloth_node";
  double fps = 30.0;
  int width = 0, height = 0;
  bool depth = false, byStrain = false, quiet = false;
};

// One image row by row to a PNG file: 8-bit RGB, or 16-bit grey (big-endian, as PNG stores it).
Status writePng(const std::string& path, int width, int height, bool rgb, const std::uint8_t* data) {
  FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr) return Error{"cannot write " + path};
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (info == nullptr || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    std::fclose(file);
    return Error{"libpng failed writing " + path};
  }
  png_init_io(png, file);
  // Fast deflate: frames are many and ffmpeg reads them once; files are about 1.5x larger.
  png_set_compression_level(png, 1);
  png_set_IHDR(png, info, width, height, rgb ? 8 : 16, rgb ? PNG_COLOR_TYPE_RGB : PNG_COLOR_TYPE_GRAY,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  const std::size_t stride = static_cast<std::size_t>(width) * (rgb ? 3 : 2);
  for (int j = 0; j < height; ++j) png_write_row(png, const_cast<std::uint8_t*>(data + j * stride));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return std::fclose(file) == 0 ? Status::success() : Status(Error{"cannot write " + path});
}

// Depth (m, NaN: nothing) as 16-bit millimetres, big-endian, 0 where nothing is seen.
std::vector<std::uint8_t> depthMillimetres(const std::vector<float>& depth) {
  std::vector<std::uint8_t> out(2 * depth.size(), 0);
  for (std::size_t k = 0; k < depth.size(); ++k) {
    if (std::isnan(depth[k])) continue;
    const long mm = std::clamp(std::lround(1000.0 * depth[k]), 0L, 65535L);
    out[2 * k] = static_cast<std::uint8_t>(mm >> 8);
    out[2 * k + 1] = static_cast<std::uint8_t>(mm & 0xff);
  }
  return out;
}

std::vector<VectorX> readPositions(const std::string& path, const std::string& topic, int dim,
                                   std::vector<ClothState>* headers) {
  rosbag::Bag bag(path, rosbag::bagmode::Read);
  std::vector<VectorX> out;
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery(topic))) {
    ClothState::ConstPtr s = m.instantiate<ClothState>();
    if (!s) continue;
    VectorX x(dim * static_cast<Index>(s->positions.size()));
    for (std::size_t i = 0; i < s->positions.size(); ++i) {
      x[dim * i] = s->positions[i].x;
      x[dim * i + 1] = s->positions[i].y;
      if (dim == 3) x[dim * i + 2] = s->positions[i].z;
    }
    out.push_back(std::move(x));
    ClothState h;
    h.header = s->header;
    h.step = s->step;
    headers->push_back(h);
  }
  return out;
}

// A camera that sees every vertex of the given states: it looks at the centre of their bounding
// box from above and to the front (+x, -y), at the distance where the box's bounding sphere
// fills the narrower field of view.
CameraSettings framingCamera(const Mesh& mesh, const std::vector<const VectorX*>& states) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (const VectorX* x : states) {
    for (Index i = 0; i < mesh.numVertices(); ++i) {
      lo = lo.cwiseMin(vertex3(mesh, *x, i));
      hi = hi.cwiseMax(vertex3(mesh, *x, i));
    }
  }
  CameraSettings c;
  c.intrinsics = CameraIntrinsics::fromHorizontalFov(960, 720, 0.9);
  const double radius = std::max(0.5 * (hi - lo).norm(), 0.05);
  const double halfFov = std::atan(0.5 * c.intrinsics.height / c.intrinsics.fy);
  const Eigen::Vector3d target = 0.5 * (lo + hi);
  const Eigen::Vector3d eye = target + 1.1 * radius / std::sin(halfFov) * Eigen::Vector3d(1.0, -1.4, 0.9).normalized();
  c.pose = *lookAt(eye, target);
  c.maxRange = 100.0 * (eye - target).norm();
  return c;
}

Expected<CameraSettings> viewCamera(const std::string& file) {
  YAML::Node doc;
  try {
    doc = YAML::LoadFile(file);
  } catch (const YAML::BadFile&) {
    return Error{"--view " + file + ": cannot read the file"};
  } catch (const YAML::Exception& e) {
    return Error{"--view " + file + " is not YAML (a view file of config/views/): " + e.msg};
  }
  // A file that is YAML but not a map (a text file reads as one scalar) has no camera either.
  if (!doc.IsMap() || !doc["camera"] || !doc["camera"].IsMap()) {
    return Error{"--view " + file + " is not a view file: it has no camera: map (see config/views/)"};
  }
  Expected<CameraSettings> c = readCameraSettings(toXmlRpc(doc["camera"]));
  if (!c) return Error{"--view " + file + ": " + c.error()};
  if (!c->pose) return Error{"--view " + file + ": camera needs a pose (position and look_at)"};
  return c;
}

// World poses of the scene's obstacles at simulation time t (ROS time `stamp`): a followed
// frame's pose from the bag's tf, the scripted offset, the shape's placement (obstacle.h).
std::vector<PlacedShape> obstaclesAt(const std::vector<Obstacle>& obstacles, const RecordedRun& run,
                                     double t, const ros::Time& stamp) {
  std::vector<PlacedShape> out;
  for (const Obstacle& o : obstacles) {
    Eigen::Isometry3d frame = Eigen::Isometry3d::Identity();
    if (!o.frame.empty()) {
      try {
        frame = tf2::transformToEigen(run.tf->lookupTransform(run.frame, o.frame, stamp));
      } catch (const tf2::TransformException&) {
        try {
          frame = tf2::transformToEigen(run.tf->lookupTransform(run.frame, o.frame, ros::Time(0)));
        } catch (const tf2::TransformException&) {
          continue;  // the bag never saw the frame: the obstacle is not drawn
        }
      }
    }
    out.push_back({o.shape, frame * Eigen::Translation3d(o.offsetAt(t)) * o.geometry});
  }
  return out;
}

void progress(std::size_t done, std::size_t total) {
  constexpr int kBar = 40;
  const int filled = total ? static_cast<int>(kBar * done / total) : kBar;
  std::fprintf(stderr, "\r[%s%s] %zu/%zu frames", std::string(filled, '#').c_str(),
               std::string(kBar - filled, '.').c_str(), done, total);
  if (done == total) std::fputc('\n', stderr);
  std::fflush(stderr);
}

// The states to draw: for frame times k / fps of simulation time, the first state at or after
// each (a state that is the first for several frame times is drawn once).
std::vector<std::size_t> pickFrames(const std::vector<ClothState>& headers, double dt, double fps) {
  std::vector<std::size_t> picked;
  std::size_t frame = 0;
  for (std::size_t k = 0; k < headers.size(); ++k) {
    const double t = static_cast<double>(headers[k].step) * dt;
    if (t + 1e-9 < static_cast<double>(frame) / fps) continue;
    picked.push_back(k);
    while (static_cast<double>(frame) / fps <= t + 1e-9) ++frame;
  }
  return picked;
}

// Draws states into numbered PNG files: the cloth and the obstacles at their poses of the time,
// and with --depth the depth image; keeps the processor time it spent rendering and writing.
class FrameWriter {
 public:
  FrameWriter(const Options& o, const CameraSettings& camera, const Model& model,
              const ObstacleSet* obstacles, const RecordedRun& recorded)
      : o_(o), camera_(camera), mesh_(model.mesh()), rest_(model.rest()), recorded_(recorded),
        view_(camera.intrinsics, camera.minRange, camera.maxRange) {
    look_.byStrain = o.byStrain;
    if (obstacles != nullptr) {
      for (std::size_t k = 0; k < obstacles->size(); ++k) obstacles_.push_back((*obstacles)[k]);
    }
  }

  // Frame number f: the state x at simulation time t (ROS time `stamp`).
  Status write(std::size_t f, const VectorX& x, double t, const ros::Time& stamp) {
    const std::clock_t begin = std::clock();
    vertexNormals(mesh_, x, normals_);
    clothVertexColours(mesh_, rest_, x, normals_, look_, colours_);
    view_.render(*camera_.pose, mesh_, x, colours_, obstaclesAt(obstacles_, recorded_, t, stamp), style_);
    const std::clock_t rendered = std::clock();
    renderSeconds_ += seconds(begin, rendered);
    const int width = camera_.intrinsics.width, height = camera_.intrinsics.height;
    char name[32];
    std::snprintf(name, sizeof(name), "frame_%05zu.png", f);
    Status s = writePng(o_.out + "/" + name, width, height, true, view_.image().rgb().data());
    if (s && o_.depth) {
      std::snprintf(name, sizeof(name), "depth_%05zu.png", f);
      s = writePng(o_.out + "/" + name, width, height, false, depthMillimetres(view_.image().depth()).data());
    }
    if (s) writeSeconds_ += seconds(rendered, std::clock());
    return s;
  }

  double renderSeconds() const { return renderSeconds_; }
  double writeSeconds() const { return writeSeconds_; }

 private:
  // Processor time of this process (the renderer is single-threaded): on a shared machine wall
  // time says more about the other processes than about ours.
  static double seconds(std::clock_t a, std::clock_t b) { return static_cast<double>(b - a) / CLOCKS_PER_SEC; }

  const Options& o_;
  const CameraSettings& camera_;
  const Mesh& mesh_;
  const RestState& rest_;
  const RecordedRun& recorded_;
  std::vector<Obstacle> obstacles_;
  ClothLook look_;
  ViewStyle style_;
  SceneView view_;
  std::vector<Eigen::Vector3d> normals_;
  std::vector<Colour> colours_;
  double renderSeconds_ = 0.0, writeSeconds_ = 0.0;
};

// The camera of --view (read before the bag), or one framing the first and last states;
// --width/--height resize it.
Expected<CameraSettings> chooseCamera(const Options& o, const std::optional<CameraSettings>& view, const Mesh& mesh,
                                      const std::vector<VectorX>& states) {
  Expected<CameraSettings> camera =
      view ? *view : Expected<CameraSettings>(framingCamera(mesh, {&states.front(), &states.back()}));
  if (camera && (o.width > 0 || o.height > 0)) {
    // Another size with the same field of view.
    const double fov = 2.0 * std::atan(0.5 * camera->intrinsics.width / camera->intrinsics.fx);
    camera->intrinsics = CameraIntrinsics::fromHorizontalFov(o.width > 0 ? o.width : camera->intrinsics.width,
                                                             o.height > 0 ? o.height : camera->intrinsics.height, fov);
  }
  return camera;
}

int run(const Options& o) {
  // The arguments before the bag is read: the view file, and an output folder that can be made.
  std::optional<CameraSettings> view;
  if (!o.view.empty()) {
    Expected<CameraSettings> c = viewCamera(o.view);
    if (!c) {
      std::cerr << "fem_cloth_render: " << c.error() << "\n";
      return 2;
    }
    view = *c;
  }
  if (std::error_code ec; !std::filesystem::create_directories(o.out, ec) && !std::filesystem::is_directory(o.out)) {
    std::cerr << "fem_cloth_render: --out " << o.out << ": cannot make the folder"
              << (ec ? ": " + ec.message() : std::string(": a file of that name exists")) << "\n";
    return 2;
  }
  Expected<RecordedRun> recorded = readRun(o.bag, o.node);
  if (!recorded) {
    std::cerr << "fem_cloth_render: " << recorded.error() << "\n";
    return 2;
  }
  if (recorded->sceneYaml.empty() || recorded->states.empty()) {
    std::cerr << "fem_cloth_render: " << o.bag << " holds no scene or no states of " << o.node << "\n";
    return 2;
  }
  Expected<YAML::Node> document = storedScene(*recorded, o.node);
  if (!document) {
    std::cerr << "fem_cloth_render: " << document.error() << "\n";
    return 2;
  }
  Expected<Scene> scene = parseScene(*document, o.bag);
  Expected<Simulation> simulation = scene ? buildSimulation(*scene) : Expected<Simulation>(Error{scene.error()});
  if (!simulation) {
    std::cerr << "fem_cloth_render: the bag's scene: " << simulation.error() << "\n";
    return 2;
  }
  const Model& model = simulation->simulator->model();
  // The states are drawn on the scene's mesh: a bag whose scene is not the mesh of its states
  // (an edited ~scene) is refused, not drawn as something else.
  if (recorded->mesh) {
    if (Status s = checkMeshMatches(*recorded->mesh, *simulation->mesh); !s) {
      std::cerr << "fem_cloth_render: bag '" << o.bag << "': " << s.error() << "\n";
      return 2;
    }
  }
  std::vector<ClothState> headers;
  const std::vector<VectorX> states = readPositions(o.bag, RunTopics(o.node).state, model.mesh().dim, &headers);
  for (std::size_t k = 0; k < states.size(); ++k) {
    if (states[k].size() != model.mesh().dim * model.mesh().numVertices()) {
      std::cerr << "fem_cloth_render: bag '" << o.bag << "': the state of step " << headers[k].step << " has "
                << states[k].size() / model.mesh().dim << " vertices, the scene's mesh "
                << model.mesh().numVertices() << ": the bag's scene is not the mesh of its states\n";
      return 2;
    }
  }
  const Expected<CameraSettings> camera = chooseCamera(o, view, model.mesh(), states);
  if (!camera) {
    std::cerr << "fem_cloth_render: " << camera.error() << "\n";
    return 2;
  }
  FrameWriter writer(o, *camera, model, simulation->simulator->obstacles(), *recorded);
  const std::vector<std::size_t> picked = pickFrames(headers, scene->dt, o.fps);
  for (std::size_t f = 0; f < picked.size(); ++f) {
    const ClothState& header = headers[picked[f]];
    const double t = static_cast<double>(header.step) * scene->dt;
    if (Status s = writer.write(f, states[picked[f]], t, header.header.stamp); !s) {
      std::cerr << "\nfem_cloth_render: " << s.error() << "\n";
      return 2;
    }
    if (!o.quiet) progress(f + 1, picked.size());
  }
  const double frames = static_cast<double>(std::max<std::size_t>(picked.size(), 1));
  std::cout << "fem_cloth_render: " << picked.size() << " frames of " << camera->intrinsics.width << " x "
            << camera->intrinsics.height << " (" << states.size() << " states, "
            << static_cast<double>(headers.back().step) * scene->dt << " s) in " << o.out
            << "; processor time a frame: rendering " << 1e3 * writer.renderSeconds() / frames
            << " ms, writing " << 1e3 * writer.writeSeconds() / frames << " ms\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"Renders a recorded fem_cloth run to PNG frames (scripts/render makes an MP4)."};
  app.add_option("bag", o.bag, "a bag of fem_cloth_node (record.launch) or fem_cloth_sim --out run.bag")
      ->required();
  app.add_option("--out", o.out, "directory for frame_NNNNN.png")->required();
  app.add_option("--view", o.view, "a view file (config/views/*.yaml): its camera; default: one that frames the cloth");
  app.add_option("--fps", o.fps, "frames per second of simulation time (30)")->check(fem_cloth::positiveNumber());
  app.add_option("--width", o.width, "image width (pixels; the field of view is kept)")->check(fem_cloth::positiveNumber());
  app.add_option("--height", o.height, "image height (pixels)")->check(fem_cloth::positiveNumber());
  app.add_flag("--depth", o.depth, "also write depth_NNNNN.png (16-bit millimetres)");
  app.add_flag("--color-by-strain", o.byStrain, "colour the cloth by strain");
  app.add_option("--node", o.node, "the node whose topics the bag holds (/fem_cloth_node)");
  app.add_flag("--quiet", o.quiet, "no progress bar");
  if (const std::optional<int> status = fem_cloth::parseToolCommandLine(app, argc, argv, "fem_cloth_render")) {
    return *status;
  }
  try {
    return run(o);
  } catch (const std::exception& e) {
    std::cerr << "fem_cloth_render: " << e.what() << "\n";
    return 2;
  }
}
