// The cloth and the obstacles seen by a pinhole camera: depth and colour images from the
// rasteriser (rasterizer.h), shaded as in shading.h. What the node's simulated camera and
// fem_cloth_render draw. ROS-free.
#pragma once

#include <vector>

#include "fem_cloth/core/mesh.h"
#include "fem_cloth/render/rasterizer.h"
#include "fem_cloth/render/shading.h"
#include "fem_cloth/render/shape_mesh.h"

namespace fem_cloth {

struct ViewStyle {
  Colour background{0.19f, 0.19f, 0.19f};
  Colour obstacle{0.62f, 0.60f, 0.57f};  ///< boxes, spheres, capsules
  Colour plane{0.42f, 0.42f, 0.44f};     ///< planes (floors, table tops)
  Light light;
};

class SceneView {
 public:
  /// Depth range (m) as in Rasterizer.
  SceneView(const CameraIntrinsics& camera, double nearRange, double farRange)
      : raster_(camera, nearRange, farRange) {}

  /// Draws one frame from a camera whose optical frame has the pose worldFromCamera (in the
  /// frame of x and of the obstacles' poses): the cloth with a colour per vertex (clothColours,
  /// mesh.numVertices() of them), then the obstacles.
  void render(const Eigen::Isometry3d& worldFromCamera, const Mesh& mesh, const VectorX& x,
              const std::vector<Colour>& clothColours, const std::vector<PlacedShape>& obstacles,
              const ViewStyle& style);

  const Rasterizer& image() const { return raster_; }
  Rasterizer& image() { return raster_; }

 private:
  Rasterizer raster_;
};

}  // namespace fem_cloth
