// Obstacle shapes (core/contact/shapes.h) as triangle meshes for drawing, in the shape's own
// frame, with unit vertex normals: each shape's own triangulation (its entry in the shape table,
// src/core/contact/shapes/<name>.cpp). ROS-free.
//   plane    a square of side `planeSide` in z = 0, centred at the origin (a plane is infinite:
//            the caller picks a side that covers what it draws, e.g. twice a camera's range)
//   box      12 triangles, 4 vertices per face so each face keeps its own flat normal
//   sphere   latitude-longitude bands, `segments` around and segments / 2 from pole to pole
//   capsule  a cylinder of `segments` sides between two hemispheres
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <vector>

#include "fem_cloth/core/contact/shapes.h"

namespace fem_cloth {

/// `segments` below 8 is taken as 8.
ShapeMesh tessellate(const Shape& shape, double planeSide, int segments = 24);

/// A shape where it is now: its world pose (the simulation frame from the shape's frame).
struct PlacedShape {
  Shape shape;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
};

}  // namespace fem_cloth
