#include "fem_cloth/core/contact/surface_reach.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "fem_cloth/core/contact/surface_samples.h"
#include "fem_cloth/core/scene.h"

namespace fem_cloth {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();

// No point is deeper in the shape than this (m).
double halfThickness(const Shape& shape) {
  return shape.type == ShapeType::Box ? shape.halfExtents.minCoeff() : shape.radius;
}

std::string millimetres(double metres) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f mm", 1e3 * metres);
  return text;
}
}  // namespace

double surfaceReachBound(const Shape& shape, double rho, double dHat, bool* through) {
  double depth = kInf;
  switch (shape.type) {
    case ShapeType::Plane:
      depth = 0.0;
      break;
    case ShapeType::Box:
      depth = std::max(rho - dHat, 0.0);
      break;
    case ShapeType::Sphere:
    case ShapeType::Capsule: {
      const double grown = shape.radius + dHat;
      if (rho < grown) depth = std::max(shape.radius - std::sqrt(grown * grown - rho * rho), 0.0);
      break;
    }
  }
  const bool passes = shape.type != ShapeType::Plane && depth >= halfThickness(shape);
  if (through != nullptr) *through = passes;
  return passes ? halfThickness(shape) : depth;
}

std::optional<SurfaceReach> findSurfaceReach(const Scene& scene) {
  if (scene.obstacles.empty()) return std::nullopt;
  Expected<Mesh> mesh = buildMesh(scene);
  if (!mesh || mesh->dim != 3) return std::nullopt;
  const double rho = scene.contact.surfaceStretch * largestRestLatticeRadius(*mesh);
  const double tolerance = surfaceTolerance(scene.contact);
  for (std::size_t i = 0; i < scene.obstacles.size(); ++i) {
    Expected<Obstacle> o = makeObstacle(scene.obstacles[i], "obstacles[" + std::to_string(i) + "]");
    if (!o) return std::nullopt;
    bool through = false;
    const double depth = surfaceReachBound(o->shape, rho, scene.contact.distance, &through);
    if (depth > tolerance) return SurfaceReach{o->name, o->shape, rho, depth, through};
  }
  return std::nullopt;
}

std::string surfaceReachText(const SurfaceReach& reach, const Scene& scene) {
  char stretch[32];
  std::snprintf(stretch, sizeof stretch, "%.3g", scene.contact.surfaceStretch);
  const std::string obstacle = shapeTypeName(reach.shape.type) + " '" + reach.obstacle + "'";
  const std::string triangle = "a triangle (points up to " + millimetres(reach.rho) +
                               " from its nearest vertex at contact.surface_stretch " + stretch + ")";
  if (reach.through) {
    return obstacle + ": it keeps the vertices contact.distance (" + millimetres(scene.contact.distance) +
           ") out, and " + triangle + " is wide enough for the obstacle to pass between its vertices";
  }
  return obstacle + ": it keeps the vertices contact.distance (" + millimetres(scene.contact.distance) +
         ") out, and between them " + triangle + " may reach up to " + millimetres(reach.depth) +
         " into it, more than contact.surface_tolerance (" + millimetres(surfaceTolerance(scene.contact)) + ")";
}

std::string surfaceReachHint(const SurfaceReach& reach, const Scene& scene) {
  const double dHat = scene.contact.distance;
  char value[32];  // rounded up to 0.1 mm
  std::snprintf(value, sizeof value, "%.4g", std::ceil(reach.depth * 1e4) / 1e4);
  if (reach.through) {
    // The stretched lattice radius below which the obstacle cannot pass through (the box's
    // bound rho - dHat, the round shapes' rho < r + dHat, at the half thickness).
    return "refine the mesh: its triangles' points must stay within " + millimetres(reach.depth + dHat) +
           " of a vertex at that stretch, now " + millimetres(reach.rho) + " (contact.surface_tolerance: " + value +
           ", the obstacle's half thickness, accepts any depth)";
  }
  return "set contact.surface_tolerance: " + std::string(value) +
         " to accept that depth, which is then measured after every substep, or refine the mesh";
}

}  // namespace fem_cloth
