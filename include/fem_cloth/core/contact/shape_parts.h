// Pieces the shape entries (src/core/contact/shapes/*.cpp) share: distances and surfaces of
// round bodies, flat faces, and the reading of a length a shape requires.
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>

#include "fem_cloth/core/contact/shapes.h"
#include "fem_cloth/core/settings_reader.h"

namespace fem_cloth {

/// Distance to a sphere of radius r about the point c: the normal is the direction away from c.
SignedDistance aroundPoint(const Eigen::Vector3d& p, const Eigen::Vector3d& c, double r);

/// A flat quad (corners counter-clockwise seen from outside), its own 4 vertices with `normal`.
void addQuad(ShapeMesh& m, const std::array<Eigen::Vector3d, 4>& corners, const Eigen::Vector3d& normal);

/// Latitude-longitude rings around the z axis, `segments` around, the upper hemisphere lifted by
/// halfLength and the lower one lowered (a sphere: 0; a capsule: a cylinder between them).
void addRoundBody(ShapeMesh& m, double radius, double halfLength, int segments);

/// The number under `key`, which a `shape` requires ("obstacles[0].radius is required for a
/// sphere (m)").
Status requiredLength(const SettingsReader& r, const std::string& key, const std::string& shape, double& out);

}  // namespace fem_cloth
