#include "fem_cloth/validate/elastica.h"

#include <array>
#include <cmath>

namespace fem_cloth::validate {

namespace {

// State (theta, theta', x, y) along sigma; x' = cos(theta), y' = sin(theta) (y downwards).
using ElasticaState = std::array<double, 4>;

ElasticaState derivative(double gamma, double sigma, const ElasticaState& s) {
  return {s[1], -gamma * (1.0 - sigma) * std::cos(s[0]), std::cos(s[0]), std::sin(s[0])};
}

/// Integrates from sigma = 0 with theta'(0) = rootCurvature; returns the state at sigma = 1.
ElasticaState shoot(double gamma, double rootCurvature, int steps) {
  ElasticaState s{0.0, rootCurvature, 0.0, 0.0};
  const double h = 1.0 / steps;
  for (int i = 0; i < steps; ++i) {
    const double sigma = i * h;
    const ElasticaState k1 = derivative(gamma, sigma, s);
    ElasticaState t;
    for (int j = 0; j < 4; ++j) t[j] = s[j] + 0.5 * h * k1[j];
    const ElasticaState k2 = derivative(gamma, sigma + 0.5 * h, t);
    for (int j = 0; j < 4; ++j) t[j] = s[j] + 0.5 * h * k2[j];
    const ElasticaState k3 = derivative(gamma, sigma + 0.5 * h, t);
    for (int j = 0; j < 4; ++j) t[j] = s[j] + h * k3[j];
    const ElasticaState k4 = derivative(gamma, sigma + h, t);
    for (int j = 0; j < 4; ++j) s[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
  }
  return s;
}

}  // namespace

ElasticaSolution heavyElastica(double gamma, int steps) {
  ElasticaSolution out;
  out.gamma = gamma;
  if (!(gamma >= 0.0) || steps < 1) return out;
  // theta'(1) = theta'(0) - gamma * integral (1 - sigma) cos(theta): negative for theta'(0) = 0,
  // >= 0 for theta'(0) = gamma / 2 (cos <= 1). Bisection keeps the root bracketed.
  double low = 0.0, high = 0.5 * gamma;
  ElasticaState end = shoot(gamma, high, steps);
  for (int i = 0; i < 200 && high - low > 1e-15 * (1.0 + gamma); ++i) {
    const double mid = 0.5 * (low + high);
    end = shoot(gamma, mid, steps);
    (end[1] < 0.0 ? low : high) = mid;
  }
  const double root = 0.5 * (low + high);
  end = shoot(gamma, root, steps);
  out.rootCurvature = root;
  out.tipAngle = end[0];
  out.tipReach = end[2];
  out.tipDrop = end[3];
  out.chordAngle = std::atan2(end[3], end[2]);
  out.ok = std::abs(end[1]) < 1e-12 * (1.0 + gamma);
  return out;
}

double peirceBendingLength(double rigidity, double weightPerArea) {
  return std::cbrt(rigidity / weightPerArea);
}

namespace {

/// The gamma in [1e-6, 1e4] where the increasing function f of the elastica reaches target
/// (bisection on log gamma).
template <class F>
double invertElastica(F f, double target) {
  double low = 1e-6, high = 1e4;
  for (int i = 0; i < 100 && high / low > 1.0 + 1e-13; ++i) {
    const double mid = std::sqrt(low * high);
    (f(heavyElastica(mid, 2000)) < target ? low : high) = mid;
  }
  return std::sqrt(low * high);
}

}  // namespace

double elasticaGammaForChordAngle(double chordAngle) {
  return invertElastica([](const ElasticaSolution& e) { return e.chordAngle; }, chordAngle);
}

double elasticaGammaForTipDrop(double tipDrop) {
  return invertElastica([](const ElasticaSolution& e) { return e.tipDrop; }, tipDrop);
}

}  // namespace fem_cloth::validate
