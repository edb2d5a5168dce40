// fem_cloth core conventions, written once for the whole library.
//
// Units: SI everywhere (REP-103): metres, kilograms, seconds, newtons, joules, pascals.
//
// Degrees of freedom: a mesh embedded in d dimensions (d = 2 for planar sheets, d = 3 for cloth)
// with n vertices stores all positions (and velocities, forces, gradients) in one flat vector of
// size d*n; coordinate k of vertex i sits at index d*i + k.
//
// Signs: every energy term reports gradient = +dE/dx. The force on the vertices is -gradient.
// Hessians are d^2E/dx^2 (so they are positive definite near a stable rest state).
//
// Deformation gradients: F = Ds * Dm^-1 with Ds = [x1 - x0, x2 - x0] (d x 2) and Dm the same
// edge matrix of the rest triangle written in its rest 2D frame. Matrix-valued quantities are
// vectorised column-major, vec(F) = [F(:,0); F(:,1)], so entry (r, c) of F is vec index r + d*c;
// a stress Hessian d^2 psi / dF^2 is a (2d) x (2d) matrix in that ordering.
#pragma once

#include <Eigen/Core>
#include <algorithm>

namespace fem_cloth {

using Index = int;

using VectorX = Eigen::VectorXd;

template <int D>
using Vec = Eigen::Matrix<double, D, 1>;

/// Deformation gradient of a triangle embedded in D dimensions: D x 2.
template <int D>
using DefGrad = Eigen::Matrix<double, D, 2>;

/// d vec(P) / d vec(F) for a D x 2 deformation gradient: (2D) x (2D).
template <int D>
using StressHessian = Eigen::Matrix<double, 2 * D, 2 * D>;

/// Element (three-vertex) vectors and matrices: 3D entries.
template <int D>
using ElementVector = Eigen::Matrix<double, 3 * D, 1>;
template <int D>
using ElementMatrix = Eigen::Matrix<double, 3 * D, 3 * D>;

/// Standard gravity (m/s^2), the floor of the acceleration scale below.
constexpr double kStandardGravity = 9.81;

/// The acceleration that sets force and energy scales of a scene (m/s^2): its gravity, but at
/// least standard gravity, so that a scene without gravity still has a scale (weight x size for
/// energies, m_i a for the unbalanced forces a step may leave, the barrier stiffness of contact).
inline double accelerationScale(double gravityNorm) {
  return std::max(gravityNorm, kStandardGravity);
}

}  // namespace fem_cloth
