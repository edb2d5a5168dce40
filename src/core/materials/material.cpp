#include "fem_cloth/core/materials/material.h"

#include <Eigen/Eigenvalues>
#include <cmath>

namespace fem_cloth {

namespace {

template <int D>
Eigen::Matrix<double, 2 * D, 1> vec(const DefGrad<D>& M) {
  return Eigen::Map<const Eigen::Matrix<double, 2 * D, 1>>(M.data());
}

template <int D>
void addMode(StressHessian<D>& H, double eigenvalue, const DefGrad<D>& mode, bool project) {
  if (project && !(eigenvalue > 0.0)) return;
  const Eigen::Matrix<double, 2 * D, 1> q = vec<D>(mode);
  H.noalias() += eigenvalue * q * q.transpose();
}

}  // namespace

template <int D>
StressHessian<D> isotropicHessian(const Svd<D>& svd, const SigmaEigensystem& eig, bool project) {
  StressHessian<D> H = StressHessian<D>::Zero();
  const auto& U = svd.U;
  const Eigen::Matrix2d& V = svd.V;
  // Scaling modes: U diag(a) V^T for the eigenvectors a of d2psi.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> scaling(eig.d2psi);
  for (int k = 0; k < 2; ++k) {
    const Eigen::Vector2d a = scaling.eigenvectors().col(k);
    addMode<D>(H, scaling.eigenvalues()[k], U * a.asDiagonal() * V.transpose(), project);
  }
  const double invSqrt2 = 1.0 / std::sqrt(2.0);
  Eigen::Matrix2d flip, twist;
  flip << 0.0, invSqrt2, invSqrt2, 0.0;
  twist << 0.0, -invSqrt2, invSqrt2, 0.0;
  addMode<D>(H, eig.flip, U * flip * V.transpose(), project);
  addMode<D>(H, eig.twist, U * twist * V.transpose(), project);
  if constexpr (D == 3) {
    const Eigen::Vector3d n = U.col(0).cross(U.col(1));
    for (int j = 0; j < 2; ++j) {
      addMode<D>(H, eig.outOfPlane[j], n * V.col(j).transpose(), project);
    }
  }
  return H;
}

template <int D>
StressHessian<D> clampEigenvalues(const StressHessian<D>& H) {
  Eigen::SelfAdjointEigenSolver<StressHessian<D>> solver(0.5 * (H + H.transpose()));
  const Eigen::Matrix<double, 2 * D, 1> clamped = solver.eigenvalues().cwiseMax(0.0);
  return solver.eigenvectors() * clamped.asDiagonal() * solver.eigenvectors().transpose();
}

template StressHessian<2> isotropicHessian<2>(const Svd<2>&, const SigmaEigensystem&, bool);
template StressHessian<3> isotropicHessian<3>(const Svd<3>&, const SigmaEigensystem&, bool);
template StressHessian<2> clampEigenvalues<2>(const StressHessian<2>&);
template StressHessian<3> clampEigenvalues<3>(const StressHessian<3>&);

}  // namespace fem_cloth
