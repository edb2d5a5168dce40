#include "fem_cloth/validate/uniaxial.h"

#include <cmath>
#include <stdexcept>

namespace fem_cloth::validate {

namespace {

/// (d psi / d s, d psi / d t) at F = diag(s, t), from the energy densities of docs/materials.md.
struct Derivatives {
  double ds = 0.0, dt = 0.0;
};

Derivatives derivatives(const std::string& model, double mu, double lambda, double s, double t) {
  if (model == "linear" || model == "corotational") {
    // mu |eps|^2 + lambda/2 (tr eps)^2 with eps = diag(s - 1, t - 1) (R = I for this F).
    const double trace = s + t - 2.0;
    return {2.0 * mu * (s - 1.0) + lambda * trace, 2.0 * mu * (t - 1.0) + lambda * trace};
  }
  if (model == "arap") return {2.0 * mu * (s - 1.0), 2.0 * mu * (t - 1.0)};
  if (model == "stvk") {
    const double e1 = 0.5 * (s * s - 1.0), e2 = 0.5 * (t * t - 1.0);
    return {(2.0 * mu * e1 + lambda * (e1 + e2)) * s, (2.0 * mu * e2 + lambda * (e1 + e2)) * t};
  }
  if (model == "neo_hookean") {
    const double logJ = std::log(s * t);
    return {mu * s - mu / s + lambda * logJ / s, mu * t - mu / t + lambda * logJ / t};
  }
  if (model == "stable_neo_hookean") {
    const double J = s * t;
    return {mu * s - mu * t + (lambda + mu) * (J - 1.0) * t, mu * t - mu * s + (lambda + mu) * (J - 1.0) * s};
  }
  throw std::invalid_argument("uniaxial: unknown material model '" + model + "'");
}

/// The root of f on [a, b] (f(a) < 0 < f(b) assumed), by bisection to round-off.
template <class F>
double bisect(const F& f, double a, double b) {
  for (int i = 0; i < 200 && b - a > 1e-15 * std::abs(a + b); ++i) {
    const double m = 0.5 * (a + b);
    (f(m) < 0.0 ? a : b) = m;
  }
  return 0.5 * (a + b);
}

}  // namespace

UniaxialState uniaxialAtStretch(const std::string& model, double mu, double lambda, double s) {
  UniaxialState out;
  out.stretch = s;
  // d psi / d t increases with t for every model here; the free side sits at its zero.
  out.transverse = bisect([&](double t) { return derivatives(model, mu, lambda, s, t).dt; }, 0.05, 3.0);
  out.stress = derivatives(model, mu, lambda, s, out.transverse).ds;
  return out;
}

UniaxialState uniaxialAtStress(const std::string& model, double mu, double lambda, double P) {
  const double s = bisect([&](double x) { return uniaxialAtStretch(model, mu, lambda, x).stress - P; }, 0.6, 3.0);
  return uniaxialAtStretch(model, mu, lambda, s);
}

}  // namespace fem_cloth::validate
