// Seeded random matrices for the core tests: rotations, rest tangent frames and deformation
// gradients. Every test draws from its own fixed seed, so a failure reproduces.
#pragma once

#include <Eigen/Geometry>
#include <Eigen/QR>
#include <cmath>
#include <random>
#include <vector>

#include "fem_cloth/core/conventions.h"

namespace fem_cloth::test_support {

class RandomMatrices {
 public:
  explicit RandomMatrices(unsigned seed) : rng_(seed) {}

  double uniform(double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng_);
  }

  /// Entries uniform in [lo, hi].
  template <int Rows, int Cols>
  Eigen::Matrix<double, Rows, Cols> matrix(double lo = -1.0, double hi = 1.0) {
    Eigen::Matrix<double, Rows, Cols> m;
    for (int c = 0; c < Cols; ++c) {
      for (int r = 0; r < Rows; ++r) m(r, c) = uniform(lo, hi);
    }
    return m;
  }

  /// A planar rotation by an angle uniform in (-pi, pi).
  Eigen::Matrix2d rotation2() { return Eigen::Rotation2Dd(uniform(-M_PI, M_PI)).toRotationMatrix(); }

  /// A 3D rotation about a random axis by an angle uniform in (-pi, pi).
  Eigen::Matrix3d rotation3() {
    Eigen::Vector3d axis = matrix<3, 1>();
    while (axis.norm() < 0.1) axis = matrix<3, 1>();
    return Eigen::AngleAxisd(uniform(-M_PI, M_PI), axis.normalized()).toRotationMatrix();
  }

  /// A random orthonormal 3 x 2 rest tangent frame (the thin Q of a random 3 x 2 matrix).
  DefGrad<3> restFrame() {
    const Eigen::Matrix3d Q = Eigen::HouseholderQR<DefGrad<3>>(matrix<3, 2>()).householderQ();
    return Q.leftCols<2>();
  }

 private:
  std::mt19937 rng_;
};

/// Rest tangent frames used by the cloth tests: the identity embedding [e1 e2], a frame tilted
/// out of the xy-plane, and random orthonormal frames.
inline std::vector<DefGrad<3>> clothRestFrames(unsigned seed, int numRandom = 3) {
  std::vector<DefGrad<3>> frames;
  DefGrad<3> T = DefGrad<3>::Zero();
  T(0, 0) = 1.0;
  T(1, 1) = 1.0;
  frames.push_back(T);
  const Eigen::Matrix3d tilt =
      Eigen::AngleAxisd(0.9, Eigen::Vector3d(1.0, -2.0, 0.5).normalized()).toRotationMatrix();
  frames.push_back(tilt * T);
  RandomMatrices random(seed);
  for (int k = 0; k < numRandom; ++k) frames.push_back(random.restFrame());
  return frames;
}

}  // namespace fem_cloth::test_support
