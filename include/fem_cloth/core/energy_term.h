// The interface every energy term of a model implements (membrane, bending; later contact).
// A term fills the gradient and the Hessian only when asked (null pointer = not needed), in the
// sign convention of conventions.h: gradient = +dE/dx.
#pragma once

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
};

}  // namespace fem_cloth
