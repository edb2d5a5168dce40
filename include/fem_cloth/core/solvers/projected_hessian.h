// The Model's PSD-projected Hessian at a point, for the solvers and integrators that read the
// stiffness without a Newton solve (the quasi-Newton solver's rest matrix, symplectic Euler's
// stable step).
#pragma once

#include "fem_cloth/core/model.h"

namespace fem_cloth {

/// The PSD-projected Hessian of all the model's terms at x, assembled into
/// model.hessianPattern() (returned).
inline SparseHessian& projectedHessian(Model& model, const VectorX& x) {
  SparseHessian& hessian = model.hessianPattern();
  hessian.setZero();
  EvalRequest request;
  request.energy = false;
  request.hessian = &hessian;
  request.hessianMode = HessianMode::Projected;
  model.evaluate(x, request);
  return hessian;
}

}  // namespace fem_cloth
