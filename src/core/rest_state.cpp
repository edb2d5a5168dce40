#include "fem_cloth/core/rest_state.h"

#include <Eigen/Geometry>
#include <cmath>
#include <string>

namespace fem_cloth {

Expected<RestState> computeRestState(const Mesh& mesh) {
  RestState rest;
  rest.dim = mesh.dim;
  const Index m = mesh.numTriangles();
  rest.DmInverse.resize(m);
  rest.restArea.resize(m);
  rest.tangentFrame.resize(m);
  rest.shapeGradients.resize(m);
  const int d = mesh.dim;
  for (Index t = 0; t < m; ++t) {
    const Triangle& tri = mesh.triangles[t];
    Eigen::Vector3d X[3];
    for (int a = 0; a < 3; ++a) {
      X[a].setZero();
      for (int k = 0; k < d; ++k) X[a][k] = mesh.restPositions[d * tri[a] + k];
    }
    const Eigen::Vector3d e1 = X[1] - X[0];
    const Eigen::Vector3d e2 = X[2] - X[0];
    Eigen::Matrix<double, 3, 2> T = Eigen::Matrix<double, 3, 2>::Zero();
    if (d == 2) {
      T(0, 0) = 1.0;
      T(1, 1) = 1.0;
    } else {
      const Eigen::Vector3d normal = e1.cross(e2);
      if (!(normal.norm() > 0.0) || !(e1.norm() > 0.0)) {
        return Error{"triangle " + std::to_string(t) + " has zero rest area"};
      }
      T.col(0) = e1.normalized();
      T.col(1) = normal.normalized().cross(T.col(0));
    }
    Eigen::Matrix2d Dm;
    Dm.col(0) = T.transpose() * e1;
    Dm.col(1) = T.transpose() * e2;
    const double det = Dm.determinant();
    if (!(std::abs(det) > 0.0) || !std::isfinite(det)) {
      return Error{"triangle " + std::to_string(t) + " has zero rest area"};
    }
    rest.DmInverse[t] = Dm.inverse();
    rest.restArea[t] = 0.5 * std::abs(det);
    rest.tangentFrame[t] = T;
    Eigen::Matrix<double, 3, 2> G;
    G.row(1) = rest.DmInverse[t].row(0);
    G.row(2) = rest.DmInverse[t].row(1);
    G.row(0) = -G.row(1) - G.row(2);
    rest.shapeGradients[t] = G;
  }
  return rest;
}

VectorX lumpedMasses(const Mesh& mesh, const RestState& rest, double arealDensity) {
  VectorX mass = VectorX::Zero(mesh.numVertices());
  for (Index t = 0; t < mesh.numTriangles(); ++t) {
    const double share = arealDensity * rest.restArea[t] / 3.0;
    for (Index v : mesh.triangles[t]) mass[v] += share;
  }
  return mass;
}

}  // namespace fem_cloth
