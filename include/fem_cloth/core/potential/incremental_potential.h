// The incremental potential of an implicit substep (Gast, Schroeder, Stomakhin, Jiang & Teran,
// "Optimization Integrator for Large Time Steps", 2015):
//
//   Phi(x) = 1/2 |x - xhat|_M^2 + c^2 sum_conservative E_t(x) + sum_dissipative Phi_t(x),
//   v+ = gamma (x+ - xc),  x+ = argmin Phi.
//
// Backward Euler: xhat = xn + h vn, c^2 = h^2, gamma = 1/h, xc = xn.
// BDF2: xhat = 4/3 xn - 1/3 xp + 8/9 h vn - 2/9 h vp, c^2 = 4/9 h^2, gamma = 3/(2h),
//   xc = (4 xn - xp)/3, with (xp, vp) the state's history; without a usable history (State::
//   hasHistory, the same step size) the substep is backward Euler.
// dPhi/dx = 0 is the implicit update M (x - xhat) = c^2 (f - dE/dx - D v+) of each scheme.
//
// The terms (potential_term.h) are evaluated in the order they were added. Conservative and load
// terms are summed first and weighted by c^2 once; the Hessian is assembled as: the first
// conservative term (the Model's, which owns the pattern) into the zeroed pattern, scaled by
// c^2 in place; the inertia M on the diagonal together with the mass-proportional terms; the
// dissipative terms; the other conservative terms, scaled by c^2, which may add entries outside
// the pattern (self-contact).
#pragma once

#include <vector>

#include "fem_cloth/core/integrators/integrator.h"
#include "fem_cloth/core/potential/potential_term.h"

namespace fem_cloth {

enum class ImplicitScheme { BackwardEuler, Bdf2 };

/// The sum of the conservative and load terms at a point.
struct TermsEvaluation {
  double stored = 0.0;  ///< sum of the conservative terms (J)
  double load = 0.0;    ///< sum of the load terms, -f.x (J)
  bool inDomain = true;
  Index firstBadElement = -1;  ///< of the Model, when it left the domain
  double energy() const { return stored + load; }
};

class IncrementalPotential {
 public:
  /// Sets the scheme's coefficients for a substep of length h from `state` (BDF2 falls back to
  /// backward Euler without a usable history), clears the terms.
  /// mass: per DOF; dim: of the mesh.
  void beginSubstep(ImplicitScheme scheme, const State& state, double h, int dim,
                    const VectorX& mass, const std::vector<char>& pinned, double fractionStart,
                    double fractionEnd);
  /// Adds a term (not owned) and calls its beginSubstep.
  void addTerm(PotentialTerm& term);

  const SubstepFrame& frame() const { return frame_; }
  bool isBdf2() const { return bdf2_; }
  double c2() const { return frame_.c2; }
  double gamma() const { return frame_.gamma; }
  const VectorX& xhat() const { return xhat_; }
  const VectorX& xc() const { return xc_; }
  const VectorX& mass() const { return *mass_; }
  const std::vector<PotentialTerm*>& terms() const { return terms_; }
  /// Whether any term bounds steps (CCD).
  bool hasStepBound() const { return !bounded_.empty(); }

  /// The conservative and load terms at x, their gradient into termGradient if not null (set,
  /// not added). Stops at the first term outside its domain.
  TermsEvaluation evaluateTerms(const VectorX& x, VectorX* termGradient);
  /// Phi at x, given the terms' evaluation there; +inf outside the domain.
  double value(const VectorX& x, const TermsEvaluation& terms);
  /// dPhi/dx at x, given the terms' gradient there.
  void gradient(const VectorX& x, const VectorX& termGradient, VectorX& out);
  /// The projected Hessian of Phi at x into `hessian` (the Model's pattern, set, not added);
  /// entries outside it as triplets into `outside` (cleared first).
  void hessian(const VectorX& x, SparseHessian& hessian,
               std::vector<Eigen::Triplet<double>>& outside);
  /// Prepares per-vertex access of every term added (PotentialTerm::prepareVertexAccess).
  void prepareVertexAccess();
  /// Readies the step-bounding terms for x + t dx and returns the largest safe t in [0, 1];
  /// with perDof (sized as x, preset to 1), also each DOF's bound (PotentialTerm::prepareStep).
  double prepareStep(const VectorX& x, const VectorX& dx, VectorX* perDof = nullptr);
  /// The size of the round-off in Phi at a point: |Phi| + 2 c^2 (|stored| + |load|).
  double roundoff(double phi, const TermsEvaluation& terms) const;

 private:
  SubstepFrame frame_;
  bool bdf2_ = false;
  VectorX xhat_, xc_;
  const VectorX* mass_ = nullptr;
  std::vector<PotentialTerm*> terms_, conservative_, dissipative_, bounded_;
};

}  // namespace fem_cloth
