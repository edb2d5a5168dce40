// A CPU z-buffer rasteriser for a simulated depth and colour camera (camera.h), ROS-free.
//
// Triangles are given in the camera's optical frame with a colour per vertex. Each pixel is
// sampled once, at its centre: it is covered when its centre lies inside the projected triangle
// (an edge shared by two triangles belongs to exactly one of them, so a closed mesh leaves no
// cracks and draws no pixel twice). Depth is z, interpolated exactly for a plane seen in
// perspective: 1/z is affine in the image coordinates, so 1/z is interpolated linearly and
// inverted; colours are interpolated perspective-correctly the same way (c/z, then times z).
// The nearest surface wins (z-buffer). Both sides of a triangle are drawn. Parts of a triangle
// nearer than the near range are clipped away (the triangle is cut by the plane z = near, so
// that a floor reaching behind the camera is still drawn in front of it); pixels farther than
// the far range stay empty, as a depth camera's beyond its range.
//
// Output: depth in metres, row-major (row 0 at the top), NaN where nothing is seen (REP-118);
// colour as 8-bit RGB, row-major, the background where nothing is seen.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "fem_cloth/render/camera.h"
#include "fem_cloth/render/colour.h"

namespace fem_cloth {

class Rasterizer {
 public:
  /// nearRange and farRange (m): the depth range drawn, 0 < near < far.
  Rasterizer(const CameraIntrinsics& camera, double nearRange, double farRange);

  const CameraIntrinsics& camera() const { return camera_; }
  double nearRange() const { return near_; }
  double farRange() const { return far_; }

  /// Starts a frame: every depth NaN, every pixel the background colour (components in [0, 1]).
  void clear(const Colour& background);
  /// Draws one triangle, vertices in the optical frame (m), colours in [0, 1].
  void drawTriangle(const std::array<Eigen::Vector3d, 3>& p, const std::array<Colour, 3>& c);

  /// z (m) of pixel (column i, row j), NaN if nothing is seen there.
  float depthAt(int i, int j) const { return depth_[index(i, j)]; }
  const std::vector<float>& depth() const { return depth_; }
  std::vector<float>& depth() { return depth_; }
  /// 3 bytes (r, g, b) per pixel.
  const std::vector<std::uint8_t>& rgb() const { return rgb_; }

 private:
  std::size_t index(int i, int j) const {
    return static_cast<std::size_t>(j) * static_cast<std::size_t>(camera_.width) +
           static_cast<std::size_t>(i);
  }
  /// A triangle wholly at z >= near.
  void drawClipped(const std::array<Eigen::Vector3d, 3>& p, const std::array<Colour, 3>& c);

  CameraIntrinsics camera_;
  double near_, far_;
  std::vector<float> depth_;
  std::vector<std::uint8_t> rgb_;
};

}  // namespace fem_cloth
