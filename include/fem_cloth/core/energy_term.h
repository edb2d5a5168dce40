// The interface every energy term of a model implements (membrane, bending; later contact).
// A term fills the gradient and the Hessian only when asked (null pointer = not needed), in the
// sign convention of conventions.h: gradient = +dE/dx.
#pragma once

#include <Eigen/SparseCore>
#include <limits>
#include <string>
#include <vector>

#include "fem_cloth/core/conventions.h"
#include "fem_cloth/core/sparse_hessian.h"

namespace fem_cloth {

enum class HessianMode {
  Exact,      ///< d^2E/dx^2 as it is (may be indefinite)
  Projected,  ///< each element's Hessian projected to positive semi-definite (for Newton)
};

constexpr double kInfiniteEnergy = std::numeric_limits<double>::infinity();

/// Element loops run in parallel (OpenMP) only from this many elements on: below it, waking the
/// thread team costs more than the work, and on a busy machine libgomp's spinning threads make
/// small parallel loops many times slower than serial ones.
constexpr int kParallelElementThreshold = 4096;

struct EvalRequest {
  bool energy = true;              ///< compute the energy (else the result's energy is 0)
  VectorX* gradient = nullptr;     ///< if set, += dE/dx
  SparseHessian* hessian = nullptr;  ///< if set, += d^2E/dx^2 into its fixed pattern
  HessianMode hessianMode = HessianMode::Projected;
};

struct EvalResult {
  double energy = 0.0;       ///< joules
  bool inDomain = true;      ///< false: some element is outside its model's domain (energy = inf)
  Index firstBadElement = -1;  ///< the first such element
};

/// Acceptance test (c) (integrators/acceptance.h): how far a term's worst element is from the
/// validity range of its model.
struct Validity {
  double measure = 0.0;  ///< the model's validity measure at the worst element
  double limit = std::numeric_limits<double>::infinity();  ///< its largest valid value
  Index element = -1;    ///< the worst element (-1: none measured)
  const char* what = "";  ///< what the measure is, for messages
  const char* advice = "";  ///< what to do about it, for messages
  bool ok() const { return !(measure > limit); }
};

class EnergyTerm {
 public:
  virtual ~EnergyTerm() = default;
  virtual std::string name() const = 0;
  /// Vertex sets whose DOFs the term couples; they define the Hessian pattern.
  virtual void appendStencils(std::vector<std::vector<Index>>* stencils) const = 0;
  /// Called once when the model builds its Hessian pattern, to cache value offsets.
  virtual void bindHessian(const SparseHessian& hessian) = 0;
  /// Evaluates at the flat positions x. Outside the domain, gradient and Hessian are left
  /// untouched for the offending elements and inDomain is false.
  virtual EvalResult evaluate(const VectorX& x, const EvalRequest& request) = 0;
  /// True if the Hessian does not depend on x (quadratic terms).
  virtual bool hasConstantHessian() const { return false; }

  /// True if the term's model is valid only in part of its domain (the linear membrane); only
  /// then is validity() evaluated.
  virtual bool hasValidityRange() const { return false; }
  /// The element with the largest validity measure at x (see Validity).
  virtual Validity validity(const VectorX& /*x*/) const { return {}; }

  // Constraint form, for solvers that visit one element at a time (XPBD): the energy of
  // element e is U_e = 1/2 C_e^T K_e C_e with k signed constraint functions C_e(x) (zero at
  // rest) and a constant k x k matrix K_e. A term without it (supportsConstraints() == false)
  // cannot be used with such solvers.
  static constexpr int kMaxConstraintsPerElement = 3;
  static constexpr int kMaxElementDofs = 12;
  virtual bool supportsConstraints() const { return false; }
  virtual Index numElements() const { return 0; }
  virtual int verticesPerElement() const { return 0; }
  virtual int constraintsPerElement() const { return 0; }
  /// The element's vertex indices (verticesPerElement() of them).
  virtual const Index* elementVertices(Index /*element*/) const { return nullptr; }
  /// C (k values) and dC/dx (k rows of verticesPerElement() * dim entries, row-major, element
  /// vertex order) at x; false outside the domain. Thread-safe.
  virtual bool elementConstraints(Index /*element*/, const VectorX& /*x*/, double* /*C*/,
                                  double* /*jacobian*/) const {
    return false;
  }
  /// K_e (k x k, row-major), constant.
  virtual void elementConstraintStiffness(Index /*element*/, double* /*K*/) const {}

  // Projective form, for Projective Dynamics (Bouaziz, Martin, Liu, Kavan & Pauly, "Projective
  // Dynamics: Fusing Constraint Projections for Fast Simulation", 2014): the energy is
  //   E(x) = sum_i w_i / 2 |S_i x - p_i(x)|^2,  p_i(x) = argmin over the element's rest-shape set,
  // with S_i acting on every coordinate alike. Then the system matrix sum_i w_i S_i^T S_i is
  // constant and the same scalar (n x n) matrix for every coordinate.
  virtual bool supportsProjective() const { return false; }
  /// Adds the scalar matrix sum_i w_i S_i^T S_i (vertex indices, n x n) as triplets.
  virtual void appendProjectiveMatrix(std::vector<Eigen::Triplet<double>>* /*triplets*/) const {}
  /// The local step: rhs += sum_i w_i S_i^T p_i(x) (a flat d*n vector).
  virtual void addProjectiveRhs(const VectorX& /*x*/, VectorX* /*rhs*/) {}
};

}  // namespace fem_cloth
