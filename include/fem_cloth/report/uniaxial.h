// Uniaxial tension of a membrane strip under plane stress, the closed form the sudden-load strip
// is checked against (test/core/test_acceptance.cpp and the stability matrix's "strip" case,
// docs/accuracy.md). The energy densities are written here from the papers, independently of
// src/core/materials, so that a wrong material or a wrong integrator both show. Header-only:
// the core tests use it without the report library.
#pragma once

#include <cmath>
#include <functional>
#include <limits>
#include <string>

namespace fem_cloth::report {

/// Energy density per unit rest area (J/m^2) of a membrane model for principal stretches
/// (s1, s2) aligned with the rest frame, with plane-stress membrane moduli
/// mu = E h / (2 (1 + nu)), lambda = E h nu / (1 - nu^2) from E h (N/m) and nu:
///   linear (Sifakis & Barbic 2012, 3.2): mu (e1^2 + e2^2) + lambda/2 (e1 + e2)^2, e = s - 1;
///   stvk (3.3): mu (E1^2 + E2^2) + lambda/2 (E1 + E2)^2, E = (s^2 - 1) / 2;
///   corotational (Kim & Eberle 2022, 5): mu sum (s - 1)^2 + lambda/2 (s1 + s2 - 2)^2;
///   arap: mu sum (s - 1)^2;
///   neo_hookean (Bonet & Wood): mu/2 (s1^2 + s2^2 - 2) - mu ln J + lambda/2 (ln J)^2, J = s1 s2;
///   stable_neo_hookean (Smith et al. 2018, 2D form): mu/2 (s1^2 + s2^2 - 2) - mu (J - 1)
///     + (lambda + mu)/2 (J - 1)^2.
/// NaN for a model without a closed form here.
inline double membraneEnergyDensity(const std::string& model, double s1, double s2,
                                    double youngsThickness, double poisson) {
  const double mu = youngsThickness / (2.0 * (1.0 + poisson));
  const double lambda = youngsThickness * poisson / (1.0 - poisson * poisson);
  const double J = s1 * s2;
  if (model == "linear") {
    const double e1 = s1 - 1.0, e2 = s2 - 1.0;
    return mu * (e1 * e1 + e2 * e2) + 0.5 * lambda * (e1 + e2) * (e1 + e2);
  }
  if (model == "stvk") {
    const double E1 = 0.5 * (s1 * s1 - 1.0), E2 = 0.5 * (s2 * s2 - 1.0);
    return mu * (E1 * E1 + E2 * E2) + 0.5 * lambda * (E1 + E2) * (E1 + E2);
  }
  const double arap = mu * ((s1 - 1.0) * (s1 - 1.0) + (s2 - 1.0) * (s2 - 1.0));
  if (model == "arap") return arap;
  if (model == "corotational") return arap + 0.5 * lambda * (s1 + s2 - 2.0) * (s1 + s2 - 2.0);
  if (model == "neo_hookean") {
    return 0.5 * mu * (s1 * s1 + s2 * s2 - 2.0) - mu * std::log(J) +
           0.5 * lambda * std::log(J) * std::log(J);
  }
  if (model == "stable_neo_hookean") {
    return 0.5 * mu * (s1 * s1 + s2 * s2 - 2.0) - mu * (J - 1.0) +
           0.5 * (lambda + mu) * (J - 1.0) * (J - 1.0);
  }
  return std::numeric_limits<double>::quiet_NaN();
}

/// Root of a monotone f on [a, b] by bisection.
inline double bisect(const std::function<double(double)>& f, double a, double b) {
  const double fa = f(a);
  for (int k = 0; k < 200; ++k) {
    const double m = 0.5 * (a + b);
    if ((f(m) > 0.0) == (fa > 0.0)) {
      a = m;
    } else {
      b = m;
    }
  }
  return 0.5 * (a + b);
}

struct PrincipalStretches {
  double axial = 1.0, transverse = 1.0;  ///< s1 along the tension, s2 across it
};

/// Uniaxial tension T (N per metre of rest width) under plane stress: the nominal stress
/// d psi / d s1 equals T while the transverse stress d psi / d s2 vanishes (s2 free), by
/// central differences of the density. Stretches up to 2 (NaN for an unknown model).
inline PrincipalStretches uniaxialStretch(const std::string& model, double tension,
                                          double youngsThickness, double poisson) {
  auto psi = [&](double s1, double s2) {
    return membraneEnergyDensity(model, s1, s2, youngsThickness, poisson);
  };
  const double eps = 1e-7;
  auto dPsi1 = [&](double s1, double s2) { return (psi(s1 + eps, s2) - psi(s1 - eps, s2)) / (2 * eps); };
  auto dPsi2 = [&](double s1, double s2) { return (psi(s1, s2 + eps) - psi(s1, s2 - eps)) / (2 * eps); };
  auto transverse = [&](double s1) { return bisect([&](double s2) { return dPsi2(s1, s2); }, 0.5, 1.5); };
  PrincipalStretches u;
  if (std::isnan(psi(1.0, 1.0))) {
    u.axial = u.transverse = std::numeric_limits<double>::quiet_NaN();
    return u;
  }
  u.axial = bisect([&](double s1) { return dPsi1(s1, transverse(s1)) - tension; }, 1.0, 2.0);
  u.transverse = transverse(u.axial);
  return u;
}

}  // namespace fem_cloth::report
