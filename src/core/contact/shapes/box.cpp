// The box: centred at the origin of its frame, half extents (hx, hy, hz) along its axes. A scene
// gives its center, orientation and full size; it is drawn as 12 triangles, 4 vertices per face
// so that each face keeps its own flat normal.
#include "fem_cloth/core/contact/shape_parts.h"
#include "fem_cloth/core/scene.h"

namespace fem_cloth {

namespace {

SignedDistance distance(const Shape& shape, const Eigen::Vector3d& p) {
  SignedDistance out;
  const Eigen::Vector3d& h = shape.halfExtents;
  Eigen::Vector3d sign;
  for (int k = 0; k < 3; ++k) sign[k] = p[k] >= 0.0 ? 1.0 : -1.0;
  const Eigen::Vector3d q = p.cwiseAbs() - h;
  const Eigen::Vector3d outside = q.cwiseMax(0.0);
  const double length = outside.norm();
  if (length > 0.0) {
    // Outside: the distance to the clamped point, across the faces, edges or corner the point is
    // beyond.
    out.distance = length;
    out.normal = sign.cwiseProduct(outside) / length;
    out.closest = p.cwiseMax(-h).cwiseMin(h);
  } else {
    // Inside (or on the surface): the nearest face.
    int face = 0;
    q.maxCoeff(&face);
    out.distance = q[face];
    out.normal = Eigen::Vector3d::Zero();
    out.normal[face] = sign[face];
    out.closest = p;
    out.closest[face] = sign[face] * h[face];
  }
  return out;
}

ShapeMesh surface(const Shape& shape, double, int) {
  ShapeMesh m;
  const Eigen::Vector3d& h = shape.halfExtents;
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    for (double side : {-1.0, 1.0}) {
      std::array<Eigen::Vector3d, 4> c;
      const double du[4] = {-1, 1, 1, -1}, dv[4] = {-1, -1, 1, 1};
      for (int k = 0; k < 4; ++k) {
        c[k][axis] = side * h[axis];
        c[k][u] = du[k] * h[u];
        c[k][v] = dv[k] * h[v];
      }
      addQuad(m, c, side * Eigen::Vector3d::Unit(axis));
    }
  }
  return m;
}

Status read(const SettingsReader& r, SceneObstacle& o) {
  FEM_CLOTH_CHECK(r.vector("center", o.center));
  FEM_CLOTH_CHECK(r.vector("orientation", o.orientation));
  if (!r.has("size")) return Error{r.where("size") + " is required for a box: [x, y, z] (m)"};
  return r.vector("size", o.size);
}

Status make(const SceneObstacle& s, const std::string& key, Obstacle& o) {
  for (int k = 0; k < 3; ++k) {
    FEM_CLOTH_CHECK(inRange(s.size[k], kMinObstacleSize, kMaxCoordinate,
                            key + ".size[" + std::to_string(k) + "]", "m"));
  }
  o.shape.halfExtents = 0.5 * s.size;
  return Status::success();
}

}  // namespace

ShapeEntry boxEntry() { return {"box", {"center", "size", "orientation"}, read, make, distance, surface}; }

}  // namespace fem_cloth
