// Points of the cloth's surface between its vertices that the barriers hold away from round
// obstacles (spheres, capsules), so that no point of an edge or a triangle passes into one.
//
// Vertex contact alone lets a round obstacle pass between vertices: a 2 cm rod rises through a
// cloth whose vertices are 8 cm apart, and a 7 cm diagonal over a 0.25 m ball sags L^2/(8R)
// = 2.5 mm into it while its ends are held outside (issue 30). The exact distance of a segment or
// a triangle to the shape moves its closest point along the element as the cloth rolls over the
// shape, and the barrier on it has curved valleys about as narrow as the element (Newton crawled:
// three times the iterations on config/sphere_drape.yaml). Instead the barriers act on fixed
// points of each triangle, a lattice of k divisions per side (barycentric coordinates (i, j, l)/k,
// i + j + l = k: the vertices, k - 1 points inside each edge, (k - 1)(k - 2)/2 inside each
// triangle), each a fixed weighted sum of its triangle's vertices, so each has a point's smooth
// distance. What holds them apart from the shape is a bound on the squared distance f to the
// shape's core (its centre, or a capsule's axis), whose Hessian is at most 2 I: for any point x of
// a sub-triangle with lattice points p_i and barycentric weights lambda_i,
//     f(x) >= sum_i lambda_i f(p_i) - sum_i lambda_i |p_i - x|^2 >= min_i f(p_i) - rho^2,
// rho^2 the largest sum_i lambda_i |p_i - x|^2 over the sub-triangle (its circumradius squared
// when acute, else half its longest side squared: latticeRadius). So lattice points kept outside
// the shape grown by delta = sqrt(r^2 + rho^2) - r (inflation) keep the whole triangle outside the
// shape itself. The barriers of the contact model see each round obstacle grown by its delta, for
// its vertices and lattice points alike.
#pragma once

#include <Eigen/Core>
#include <array>
#include <vector>

#include <cmath>

#include "fem_cloth/core/conventions.h"

namespace fem_cloth {

struct Mesh;

/// A point of the surface: sum of weights[i] x_{vertices[i]} over `count` vertices (2: an edge's,
/// 3: a triangle's).
struct SurfaceSample {
  std::array<Index, 3> vertices{};
  Eigen::Vector3d weights = Eigen::Vector3d::Zero();
  int count = 0;
  double mass = 0.0;  ///< kg: its barrier's weight, sum_i w_i m_i / k^2
};

/// rho of the triangle (a, b, c): the largest sum_i lambda_i |p_i - x|^2 over its points x,
/// square-rooted (m).
double latticeRadius(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c);
/// latticeRadius of triangle t (its vertex indices) of the mesh at rest (m).
double restLatticeRadius(const Mesh& mesh, const std::array<Index, 3>& t);
/// The largest restLatticeRadius over the mesh's triangles (m).
double largestRestLatticeRadius(const Mesh& mesh);

/// delta (m): how much a round shape of radius r must grow so that a triangle whose lattice
/// points are all outside the grown shape, with lattice radius rho, is outside the shape itself.
inline double inflation(double radius, double rho) {
  return std::sqrt(radius * radius + rho * rho) - radius;
}

/// The lattice points of every triangle of the mesh for k divisions, other than its vertices,
/// each once (edge points are shared by the two triangles of the edge). Empty for k = 1.
std::vector<SurfaceSample> surfaceSamples(const Mesh& mesh, const VectorX& vertexMass, int divisions);

}  // namespace fem_cloth
