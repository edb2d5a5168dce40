#include "fem_cloth/core/contact/ccd.h"

#include <cmath>

#include "fem_cloth/core/contact/primitive_distance.h"

namespace fem_cloth::ccd {

namespace {

using Matrix34 = Eigen::Matrix<double, 3, 4>;

// firstSide: how many of the four vertices form the first primitive (1 for a point, 2 for an edge).
template <class Distance>
double pair(const Matrix34& x, Matrix34 dx, double tMax, int firstSide, Distance distance) {
  // A common translation does not change the distance: remove the mean motion.
  const Eigen::Vector3d mean = dx.rowwise().mean();
  dx.colwise() -= mean;
  double first = 0.0, second = 0.0;
  for (int k = 0; k < 4; ++k) {
    double& side = k < firstSide ? first : second;
    side = std::max(side, dx.col(k).norm());
  }
  auto at = [&](double t) {
    const Matrix34 y = x + t * dx;
    return std::sqrt(distance(y));
  };
  return additive(at, at(0.0), first + second, tMax);
}

}  // namespace

double pointTriangle(const Matrix34& x, const Matrix34& dx, double tMax) {
  return pair(x, dx, tMax, 1, [](const Matrix34& y) {
    return pointTriangleDistance(y.col(0), y.col(1), y.col(2), y.col(3)).squared;
  });
}

double edgeEdge(const Matrix34& x, const Matrix34& dx, double tMax) {
  return pair(x, dx, tMax, 2, [](const Matrix34& y) {
    return edgeEdgeDistance(y.col(0), y.col(1), y.col(2), y.col(3)).squared;
  });
}

}  // namespace fem_cloth::ccd
