// The corners and edges of a box, and the exact distance of a triangle to it: what the contact
// model needs so that no point of the cloth's surface, not only its vertices, enters a box.
//
// Vertex-box barriers keep vertices out of a box, not the points between them: a table's edge
// cuts 13 mm into the triangles draped over it (config/table_drape.yaml, issue 30). For two
// convex polyhedra the closest points lie on a vertex of one and a face of the other, or on an
// edge of each (Incremental Potential Contact, Li et al. 2020, section 4: point-triangle and
// edge-edge pairs). Against a box, the cloth's vertices are covered by the box's own distance
// (shapes.h); what is left is each box corner against each cloth triangle and each box edge
// against each cloth edge. A box is centred at the origin of its frame, axis-aligned there, with
// half extents h (m).
#pragma once

#include <Eigen/Core>
#include <array>

namespace fem_cloth::box {

constexpr int kCorners = 8;
constexpr int kEdges = 12;

/// Corner i (0-7): bit a of i set means +h_a along axis a, else -h_a.
inline Eigen::Vector3d corner(const Eigen::Vector3d& h, int i) {
  return {(i & 1) ? h.x() : -h.x(), (i & 2) ? h.y() : -h.y(), (i & 4) ? h.z() : -h.z()};
}

/// Edge j (0-11) as its two corners: edges 4a to 4a + 3 run along axis a.
inline std::array<int, 2> edge(int j) {
  const int axis = j / 4, m = j % 4;
  // The two other axes' bits from m, axis a's bit clear.
  const int low = m & ((1 << axis) - 1), high = (m >> axis) << (axis + 1);
  const int first = low | high;
  return {first, first | (1 << axis)};
}

/// Whether the triangle's three vertices lie beyond the plane of one face (strictly): then no
/// point of it is in the box (a cheap test that settles most triangles, a cloth on a table top).
inline bool beyondOneFace(const Eigen::Vector3d& h, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                          const Eigen::Vector3d& c) {
  return ((a.array() > h.array()) && (b.array() > h.array()) && (c.array() > h.array())).any() ||
         ((a.array() < -h.array()) && (b.array() < -h.array()) && (c.array() < -h.array())).any();
}

/// Whether the triangle (a, b, c) and the box (closed sets: touching counts) have a point in
/// common: the separating-axis test over the box's three face normals, the triangle's normal and
/// the nine cross products of their edges (Akenine-Moeller, "Fast 3D Triangle-Box Overlap
/// Testing", 2001). Box frame.
bool overlapsTriangle(const Eigen::Vector3d& h, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                      const Eigen::Vector3d& c);

/// The distance (m) between the triangle (a, b, c) and the box, box frame: exact when they are
/// apart (the smallest of the triangle's vertices to the box, the box's corners to the triangle
/// and the box's edges to the triangle's edges), 0 when they overlap.
double triangleDistance(const Eigen::Vector3d& h, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                        const Eigen::Vector3d& c);

}  // namespace fem_cloth::box
