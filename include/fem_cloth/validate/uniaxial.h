// Uniaxial tension of a membrane strip in closed form, for every material model, written out
// here from the energy densities of docs/materials.md (independently of the model code): with
// F = diag(s, t) (stretch s along the load, t across), the transverse stretch t makes
// d psi / d t = 0 (free sides), and the nominal stress (force per unit rest width, N/m) is
// P = d psi / d s. At nu = 0 (lambda = 0) t = 1 for all models but Stable Neo-Hookean, and
//   linear, corotational, arap:  P = 2 mu (s - 1)
//   stvk:                        P = mu (s^2 - 1) s
//   neo_hookean:                 P = mu (s - 1 / s)
//   stable_neo_hookean:          t = 2 s / (1 + s^2), P = mu (s - t) + mu (s t - 1) t
// For nu > 0 t is found by bisection on d psi / d t (analytic derivatives below).
#pragma once

#include <string>

namespace fem_cloth::validate {

struct UniaxialState {
  double stretch = 1.0;     ///< s
  double transverse = 1.0;  ///< t
  double stress = 0.0;      ///< P (N/m for membrane moduli in N/m)
};

/// Uniaxial response at stretch s for a model name and membrane Lame parameters mu, lambda (N/m).
UniaxialState uniaxialAtStretch(const std::string& model, double mu, double lambda, double s);
/// The stretch s at which the nominal stress is P (bisection on s in (0.2, 5)).
UniaxialState uniaxialAtStress(const std::string& model, double mu, double lambda, double P);

}  // namespace fem_cloth::validate
