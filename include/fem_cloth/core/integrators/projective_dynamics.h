// Projective Dynamics (Bouaziz, Martin, Liu, Kavan & Pauly, "Projective Dynamics: Fusing
// Constraint Projections for Fast Simulation", SIGGRAPH 2014): the fast implicit path.
//
// It minimises backward Euler's incremental potential
//   Phi(x) = 1/(2h^2) |x - xhat|_M^2 - f.x + sum_i w_i/2 |S_i x - p_i|^2
// for energies in projective form (energy_term.h): the ARAP membrane, psi = mu |F - R|^2, and the
// quadratic bending model. Alternating a local step (every element's projection p_i, here the
// closest rotation, in parallel) and a global step (one linear solve with the matrix
//   A = M/h^2 + sum_i w_i S_i^T S_i,
// which is constant, the same for x, y and z, and so factorised once per pin set) decreases Phi
// monotonically; converged, it is backward Euler on ARAP. A fixed number of iterations bounds
// the cost per step (a few back-substitutions), which is what makes stiff cloth cheap; with too
// few iterations the cloth is softer than its material, which the accuracy report measures.
// Optional Chebyshev acceleration (Wang, "A Chebyshev Semi-Iterative Approach for Accelerating
// Projective and Position-based Dynamics", SIGGRAPH Asia 2015).
//
// Pins are Dirichlet conditions: pinned vertices are removed from A (refactorised when the set
// of pinned vertices changes, not when targets move). Mass-proportional damping enters A as in
// backward Euler; stiffness-proportional damping is not supported.
#pragma once

#include "fem_cloth/core/air.h"
#include "fem_cloth/core/integrators/integrator.h"
#include "fem_cloth/core/solvers/lbfgs.h"
#include "fem_cloth/core/solvers/scalar_cholesky.h"

namespace fem_cloth {

struct ProjectiveDynamicsSettings {
  /// Local/global iterations per substep before the error is first measured; quasi-Newton
  /// iterations follow until acceptance test (a) in displacement holds or maxIterations of them
  /// are spent.
  int iterations = 10;
  int maxIterations = 500;
  double chebyshevRho = 0.0;  ///< spectral radius estimate for Chebyshev acceleration; 0: off
};

class ProjectiveDynamics final : public Integrator {
 public:
  explicit ProjectiveDynamics(ProjectiveDynamicsSettings settings = {}) : settings_(settings) {}
  std::string name() const override { return "projective_dynamics"; }
  bool needsHessian() const override { return false; }
  StepReport step(const StepInput& input, State& state, double dt, int minSubsteps,
                  VectorX& pinForce) override;
  void invalidate() override { factorisedFor_.clear(); }

  /// Number of factorisations so far (one per pin set and step size).
  int factorisations() const { return factorisations_; }

 private:
  using Matrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
  /// Builds and factorises A on the free vertices, if the pin set or the step changed.
  bool prepare(const StepInput& input, double h, std::string* error);
  /// `count` local/global iterations of the substep from state.x (Chebyshev continues).
  void iterate(const StepInput& input, State& state, double h, int count);
  /// Acceptance test (a) at x: backward Euler's unbalanced forces on the true energy (into
  /// force_, which on pinned DOFs is what the pins supply); sets velocity_, and Phi(x) if asked.
  ForceResidual residual(const StepInput& input, const VectorX& x, double h,
                         double* potential = nullptr);
  /// More iterations, by quasi-Newton, from state.x until acceptance test (a) in displacement
  /// holds or maxIterations are spent; returns the error at the final state.x.
  DisplacementError quasiNewton(const StepInput& input, State& state, double h, int substeps);
  /// Test (a) at state.x (force_ and velocity_ evaluated there) with dx the correction still to
  /// make, after a move `moved` long (remainingErrorFactor), in one of `substeps` substeps.
  DisplacementError displacementError(const StepInput& input, const State& state, double h,
                                      const VectorX& dx, double moved, int substeps);
  /// direction_ = -H g_ (the L-BFGS two-loop recursion on A^-1).
  void direction();
  /// z = A^-1 q on the free DOFs (zero on pinned ones), with factor_.
  void applyInverse(const VectorX& q, VectorX& z);

  ProjectiveDynamicsSettings settings_;
  Matrix laplacian_;            // sum_i w_i S_i^T S_i, all vertices (built once)
  bool haveLaplacian_ = false;
  std::vector<char> factorisedFor_;  // pinned flags per vertex of the current factorisation
  std::vector<char> pinnedVertices_;  // the same for this step (a buffer: no allocation per step)
  double factorisedH_ = 0.0;
  int factorisations_ = 0;
  std::vector<Index> freeIndex_;   // vertex -> row in the free system (-1 if pinned)
  std::vector<Index> freeVertices_;
  Matrix systemFree_;              // A restricted to free vertices
  Matrix couplingFreePinned_;      // A(free, pinned): moves pinned targets to the right side
  ScalarCholesky factor_;          // of systemFree_, for every coordinate
  // Scratch (sized once).
  VectorX xhat_, rhs_, xPrev_, xPrevPrev_, vStart_, force_, velocity_;
  LaggedAir air_;  // air only
  double omega_ = 1.0;  // Chebyshev weight of the last iteration
  // Quasi-Newton: the gradient, a direction, a trial point and the L-BFGS curvature pairs.
  static constexpr int kMemory = 6;
  /// How much -H g may understate the distance to the converged step (measured, not derived),
  /// and so by how much error_ratio is cut for projective dynamics: A, and so H off the pairs'
  /// span, carries the membrane's stiffness L in every coordinate, also in the soft out-of-plane
  /// modes whose true Hessian is little more than M / h^2. On the 9 x 9 hanging ARAP cloth
  /// (test_projective_dynamics, 10 steps of 0.01 s, started from 2, 8 and 32 local/global
  /// iterations) error_ratio 0.1 as it is left 0.59, 0.33 and 0.27 x backward Euler's own error
  /// (dt against dt/8) between PD and the converged steps; cut by 10, 0.09, 0.28 and 0.11 x; by
  /// 20, 0.03, 0.04 and 0.05 x. On config/hanging_cloth_fast.yaml (65 x 65, 0.2 s) by 20: 217
  /// iterations per step and 0.03 x RMS (0.08 x at the worst vertex).
  static constexpr double kUnderstatement = 20.0;
  VectorX g_, gTrial_, direction_, trial_;
  LbfgsHistory history_{kMemory};
  int iteration_ = 0;   // iterations of the substep so far
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rhsFree_, solFree_;
  Eigen::MatrixXd pinnedPositions_;
};

}  // namespace fem_cloth
