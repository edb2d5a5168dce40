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
//
// Contact (setContact): the barriers' and friction's 3 x 3 Hessian blocks D_v at the vertices in
// contact (c^2-weighted, PSD) stand for H0 ~ B0 x I3 + D, D block diagonal. B0 is scalar (one
// matrix for x, y and z) and a barrier's block is not (stiff along its normal). By default
// (ContactOptions, measured in docs/integrators.md, Quasi-Newton) each block's trace / 3 goes into
// the scalar matrix's diagonal, taken at the substep's first iterate and kept through the substep,
// and B0 is refactorised when that diagonal changes (an n x n numeric factorisation, cheap against
// the iterations it saves). Measured and kept as options: conjugate gradients on (B0 x I3 + D) z = q
// preconditioned by the factor (started from z = 0, so that q.z > 0 and -H g still descends; D
// can then follow every iterate without a refactorisation), and retaking the trace at every
// iterate. Both took more iterations or more time on the contact scenes: CG makes H0 depend on q
// (not one matrix), which the L-BFGS pairs do not model.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "fem_cloth/core/model.h"
#include "fem_cloth/core/solvers/scalar_cholesky.h"

namespace fem_cloth {

class InitialHessian {
 public:
  using Matrix = ScalarCholesky::Matrix;
  struct ContactBlock {
    Index vertex = 0;
    Eigen::Matrix3d block = Eigen::Matrix3d::Zero();  ///< c^2-weighted, PSD (Phi's units per m^2)
  };
  struct ContactOptions {
    bool traceInFactor = true;  ///< add trace(D_v) / traceDivisor to B0's diagonal (refactorises on change)
    double traceDivisor = 3.0;
    bool followIterate = false;  ///< with traceInFactor: retake D (and refactorise) at every iterate
    int pcgIterations = 0;       ///< CG iterations on (B0 x I3 + D) per application; 0: the factor alone
    double pcgTolerance = 1e-2;  ///< stop earlier when the preconditioned residual fell by this
  };
  /// Fills the contact's blocks at positions x (the free vertices with a nonzero block).
  using ContactSource = std::function<void(const VectorX& x, std::vector<ContactBlock>& blocks)>;
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
  bool prepare(Model& model, const std::vector<char>& pinned, double a, double b, const VectorX& x,
               std::string* error);
  /// z = H0 q on the free DOFs, zero on pinned ones: B0^-1 q, or with contact blocks the CG
  /// approximation of (B0 x I3 + D)^-1 q.
  void applyInverse(const VectorX& q, VectorX& z);
  /// The contact for the substep: `source` fills the blocks (empty function: no contact). Call
  /// before prepare(), which takes the blocks at x; refreshContact(x) retakes them at a new
  /// iterate when that needs no refactorisation (not with traceInFactor).
  void setContact(ContactSource source, const ContactOptions& options);
  /// False if the refactorisation failed (not SPD).
  bool refreshContact(const VectorX& x);
  std::size_t contactVertices() const { return contact_.size(); }
  /// L over all vertices (built by prepare).
  const Matrix& laplacian() const { return laplacian_; }
  int factorisations() const { return factorisations_; }

 private:
  void buildLaplacian(Model& model);
  /// The contact blocks at x, and the free-vertex diagonal they add to the factor.
  void takeContact(const VectorX& x);
  bool factorise(std::string* error);
  /// Y = (B0 x I3 + D) Z on the free vertices.
  void applySystem(const ScalarCholesky::Block& Z, ScalarCholesky::Block& Y) const;
  void conjugateGradients();  ///< solution_ from rhs_ (the contact case of applyInverse)

  Matrix laplacian_, system_;
  bool haveLaplacian_ = false;
  int dim_ = 3;
  std::vector<char> pinnedVertices_, factorisedFor_;
  double a_ = 0.0, b_ = 0.0;
  int factorisations_ = 0;
  std::vector<Index> freeVertices_, freeIndex_;
  ScalarCholesky factor_;
  ScalarCholesky::Block rhs_, solution_, r_, s_, p_, ap_;
  ContactSource source_;
  ContactOptions options_;
  std::vector<ContactBlock> contact_;
  VectorX diagonal_, factorisedDiagonal_;  // per free vertex: trace(D_v) / 3 (traceInFactor)
};

}  // namespace fem_cloth
