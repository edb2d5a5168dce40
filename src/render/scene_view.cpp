#include "fem_cloth/render/scene_view.h"

namespace fem_cloth {

void SceneView::render(const Eigen::Isometry3d& worldFromCamera, const Mesh& mesh, const VectorX& x,
                       const std::vector<Colour>& clothColours,
                       const std::vector<PlacedShape>& obstacles, const ViewStyle& style) {
  const Eigen::Isometry3d cameraFromWorld = worldFromCamera.inverse();
  raster_.clear(style.background);
  for (const Triangle& t : mesh.triangles) {
    raster_.drawTriangle({cameraFromWorld * vertex3(mesh, x, t[0]), cameraFromWorld * vertex3(mesh, x, t[1]),
                          cameraFromWorld * vertex3(mesh, x, t[2])},
                         {clothColours[t[0]], clothColours[t[1]], clothColours[t[2]]});
  }
  for (const PlacedShape& o : obstacles) {
    // A plane is infinite: a square around its point that reaches every point of it within the
    // camera's range is all of it the camera can see.
    const double reach = raster_.farRange() + (worldFromCamera.translation() - o.pose.translation()).norm();
    const ShapeMesh shape = tessellate(o.shape, 2.0 * reach);
    const Eigen::Isometry3d cameraFromShape = cameraFromWorld * o.pose;
    const Colour base = o.shape.type == ShapeType::Plane ? style.plane : style.obstacle;
    std::vector<Colour> colours(shape.positions.size());
    for (std::size_t k = 0; k < colours.size(); ++k) {
      colours[k] = shade(base, o.pose.linear() * shape.normals[k], style.light);
    }
    for (const auto& t : shape.triangles) {
      raster_.drawTriangle({cameraFromShape * shape.positions[t[0]], cameraFromShape * shape.positions[t[1]],
                            cameraFromShape * shape.positions[t[2]]},
                           {colours[t[0]], colours[t[1]], colours[t[2]]});
    }
  }
}

}  // namespace fem_cloth
