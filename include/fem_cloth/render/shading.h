// How the cloth and the obstacles look: smooth per-vertex shading with one directional light
// baked into vertex colours, the same in the RViz marker, the simulated colour camera and
// fem_cloth_render. ROS-free.
//
// Vertex normals are area-weighted: the sum over a vertex's triangles of (x1 - x0) x (x2 - x0),
// whose length is twice the triangle's area, normalised (Gouraud 1971 shading with the weights
// Max compares in "Weights for Computing Vertex Normals from Facet Normals", JGT 1999). The light
// is Lambertian and two-sided: intensity = ambient + diffuse |n . l|, so the back of the cloth is
// lit like its front (a cloth has no outside), and vertex colours interpolated over a triangle
// give smooth shading (RViz draws a triangle list with vertex colours unlit, as given).
#pragma once

#include <Eigen/Geometry>
#include <vector>

#include "fem_cloth/core/mesh.h"
#include "fem_cloth/core/rest_state.h"
#include "fem_cloth/render/colour.h"

namespace fem_cloth {

struct Light {
  /// Towards the light, in the frame the geometry is given in (normalised where used).
  Eigen::Vector3d direction{0.45, -0.6, 0.66};
  float ambient = 0.35f;
  float diffuse = 0.65f;
};

/// Area-weighted unit vertex normals of the mesh at positions x (2D meshes: +z everywhere). A
/// vertex whose triangles have no area in total (unused, or every triangle collapsed) gets +z.
void vertexNormals(const Mesh& mesh, const VectorX& x, std::vector<Eigen::Vector3d>& normals);

/// Per-vertex values from per-triangle values: the mean over a vertex's triangles weighted by
/// their areas at x (0 for a vertex without area).
void vertexAverages(const Mesh& mesh, const VectorX& x, const std::vector<double>& perTriangle,
                    std::vector<double>& perVertex);

/// base (ambient + diffuse |n . l|), each component at most 1.
Colour shade(const Colour& base, const Eigen::Vector3d& normal, const Light& light);

/// Blue (unstrained) through white to red (strain >= maxStrain, maxStrain > 0).
Colour strainColour(double strain, double maxStrain);

/// What colour the cloth's vertices take.
struct ClothLook {
  Colour colour{0.25f, 0.45f, 0.85f};  ///< the fabric's colour, when not coloured by strain
  bool byStrain = false;               ///< colour by strain (strainColour) instead
  double strainColourMax = 0.05;       ///< strain (s1 - 1) shown fully red
  Light light;
};

/// Shaded vertex colours of the cloth at x from its unit vertex normals; with look.byStrain the
/// base colour is strainColour of the area-weighted vertex strain (largest principal stretch
/// minus one, metrics.h), which needs the rest state.
void clothVertexColours(const Mesh& mesh, const RestState& rest, const VectorX& x,
                        const std::vector<Eigen::Vector3d>& normals, const ClothLook& look,
                        std::vector<Colour>& colours);

}  // namespace fem_cloth
