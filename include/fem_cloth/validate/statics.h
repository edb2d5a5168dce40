// Static equilibrium of a simulation's model under its gravity and commanded forces, with its
// pins fixed at their targets: minimises Phi(x) = E(x) - f . x over the free DOFs.
//
// Newton on Phi with the PSD-projected Hessian, damped Levenberg-Marquardt style
// ((H + lambda d I) dx = -g, d the mean Hessian diagonal, lambda cut tenfold after every
// accepted step and raised tenfold after a rejected one), so free-floating bodies (rigid modes)
// and large rotations are solved alike; the load is applied in `loadSteps` equal increments
// (continuation). Success means the force residual |dPhi/dx| on every free DOF is below
// `tolerance` times the largest nodal load (or the round-off floor of the forces, when that is
// larger): a result that is not converged says so.
#pragma once

#include <string>

#include "fem_cloth/core/scene.h"

namespace fem_cloth::validate {

struct StaticSettings {
  int loadSteps = 1;
  int maxIterations = 200;  ///< per load step
  /// On max |residual| / max nodal load. 1e-8: stiff membranes (E h / load per vertex ~ 1e9)
  /// leave a round-off floor near 1e-9.
  double tolerance = 1e-8;
};

struct StaticResult {
  bool converged = false;
  int iterations = 0;       ///< Newton iterations over all load steps
  double residual = 0.0;    ///< max |dPhi/dx| over free DOFs / max nodal load, at the end
  /// The tolerance applied: settings.tolerance, or the round-off floor 10 eps |x| K / load when
  /// that is larger (K the largest diagonal stiffness).
  double tolerance = 0.0;
  std::string error;        ///< why it failed, when it did
};

/// Solves for the equilibrium of `sim` starting from its current state and leaves it in the
/// simulator's state (velocities zero). Gravity and the commanded external forces are the load.
StaticResult solveStatics(Simulation& sim, const StaticSettings& settings = {});

}  // namespace fem_cloth::validate
