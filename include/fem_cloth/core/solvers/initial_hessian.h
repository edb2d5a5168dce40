// The constant initial Hessian of the quasi-Newton solver (solvers/lbfgs.h):
//
//   B0 = a M + b L,  a = 1 + c^2 gamma alpha,  b = c^2 (1 + gamma beta),
//
// the incremental potential's Hessian M + c^2 K (with Rayleigh damping alpha M + beta K) where the
// stiffness K is replaced by L, a scalar (vertex x vertex) matrix from the rest state, the same
// for every coordinate (Liu, Bouaziz & Kavan, "Quasi-Newton Methods for Real-Time Simulation of
// Hyperelastic Materials", 2017, section 4: projective dynamics' Laplacian-like matrix).
//
// L is the partial trace over the coordinates of the Model's PSD-projected elastic Hessian at the
// rest positions, divided by kLaplacianTraceDivisor: L(u, v) = sum_k K(d u + k, d v + k) /
// divisor. Every term contributes (membrane of any material, any bending model), so L carries
// each one's stiffness, and it is PSD (a sum of principal submatrices of a PSD matrix) and
// rotation invariant (a rotation R of the coordinates turns the blocks K_uv into R K_uv R^T,
// whose trace is the same), so it fits a cloth in any orientation, as projective dynamics'
// matrix does; for the ARAP membrane it is half that matrix (test_lbfgs). Pinned vertices are
// removed.
// B0 is factorised once (ScalarCholesky) and refactorised only when the pinned vertices, a or b
// change (a new step size, damping), or invalidate() says the model did (a stiffness changed).
#pragma once

#include <string>
#include <vector>

#include "fem_cloth/core/model.h"
#include "fem_cloth/core/solvers/scalar_cholesky.h"

namespace fem_cloth {

class InitialHessian {
 public:
  using Matrix = ScalarCholesky::Matrix;
  /// The mean over the three coordinates. The partial trace of an isotropic membrane's rest
  /// Hessian is (3 mu + lambda) A g_a.g_b per triangle, that of ARAP 3 mu A g_a.g_b (g the shape
  /// gradients), so L is mu A g_a.g_b for ARAP, half projective dynamics' 2 mu A g_a.g_b. A
  /// softer L than that matrix serves L-BFGS better: the stiffness is in the plane, and B0 also
  /// stands for the soft normal direction. Measured on the 33 x 33 hanging cloth, 0.2 s at dt
  /// 0.01: 49.5 iterations per step with divisor 3 against 68.1 with 1.5 (stable_neo_hookean;
  /// stvk 51.4 against 78.1, arap 46.3 against 59.5), 79 with 1, 59 with 6.
  static constexpr double kLaplacianTraceDivisor = 3.0;

  /// Drops L and the factor (the model's topology or stiffness changed).
  void invalidate();
  /// Readies B0 for a substep (builds L on first use, refactorises when needed); false with
  /// `error` set if the matrix is not SPD.
  bool prepare(Model& model, const std::vector<char>& pinned, double a, double b, std::string* error);
  /// z = B0^-1 q on the free DOFs, zero on pinned ones.
  void applyInverse(const VectorX& q, VectorX& z);
  /// L over all vertices (built by prepare).
  const Matrix& laplacian() const { return laplacian_; }
  int factorisations() const { return factorisations_; }

 private:
  void buildLaplacian(Model& model);

  Matrix laplacian_, system_;
  bool haveLaplacian_ = false;
  int dim_ = 3;
  std::vector<char> pinnedVertices_, factorisedFor_;
  double a_ = 0.0, b_ = 0.0;
  int factorisations_ = 0;
  std::vector<Index> freeVertices_;
  ScalarCholesky factor_;
  ScalarCholesky::Block rhs_, solution_;
};

}  // namespace fem_cloth
