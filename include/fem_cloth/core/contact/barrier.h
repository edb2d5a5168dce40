// The scalar functions of Incremental Potential Contact (Li, Ferguson, Schneider, Langlois, Zorin,
// Panozzo, Jiang & Kaufman, "Incremental Potential Contact", SIGGRAPH 2020):
//
// - the log barrier of section 4.1, written in the squared distance s = d^2 with sHat = dHat^2
//   as in the paper's implementation (no square roots in derivatives):
//       b(s) = -(s - sHat)^2 ln(s / sHat)  for 0 < s < sHat,   0 for s >= sHat,   +inf for s <= 0;
//   it is C2 at s = sHat and grows without bound as the distance goes to zero, so a minimiser of
//   an energy that contains it never has a distance of zero (no contact is ever penetrated);
// - the smoothed friction of section 5.2: with y the tangential relative displacement over a step
//   and eps = eps_v h the displacement below which friction is treated as static,
//       f1(y) = -y^2/eps^2 + 2 y/eps  for y < eps, else 1     (the friction force factor)
//       f0(y) = -y^3/(3 eps^2) + y^2/eps + eps/3  for y < eps, else y     (f0' = f1)
//   so the friction potential mu lambda f0(|u|) gives a force of magnitude mu lambda f1(|u|):
//   exactly Coulomb's mu lambda when sliding, growing smoothly from zero when (almost) sticking;
// - the edge-edge mollifier of section 4.3 that fades the barrier of nearly parallel edges.
#pragma once

#include <cmath>
#include <limits>

namespace fem_cloth::barrier {

/// b(s), b'(s), b''(s) for s = d^2 (m^2); b has units m^4.
inline double value(double s, double sHat) {
  if (s >= sHat) return 0.0;
  if (s <= 0.0) return std::numeric_limits<double>::infinity();
  const double a = s - sHat;
  return -a * a * std::log(s / sHat);
}

inline double first(double s, double sHat) {
  if (s >= sHat || s <= 0.0) return 0.0;
  const double a = s - sHat;
  return -2.0 * a * std::log(s / sHat) - a * a / s;
}

inline double second(double s, double sHat) {
  if (s >= sHat || s <= 0.0) return 0.0;
  const double a = s - sHat;
  return -2.0 * std::log(s / sHat) - 4.0 * a / s + a * a / (s * s);
}

}  // namespace fem_cloth::barrier

namespace fem_cloth::friction {

inline double f0(double y, double eps) {
  if (y >= eps) return y;
  return -y * y * y / (3.0 * eps * eps) + y * y / eps + eps / 3.0;
}

inline double f1(double y, double eps) {
  if (y >= eps) return 1.0;
  return -y * y / (eps * eps) + 2.0 * y / eps;
}

/// f1(y) / y, finite as y -> 0 (2 / eps).
inline double f1OverY(double y, double eps) {
  if (y >= eps) return 1.0 / y;
  return -y / (eps * eps) + 2.0 / eps;
}

/// (f1'(y) y - f1(y)) / y^3, the coefficient of u u^T in the Hessian of f0(|u|); finite as
/// y -> 0 once multiplied by |u|^2 (-1 / (eps^2 y)).
inline double hessianRadialCoefficient(double y, double eps) {
  if (y >= eps) return -1.0 / (y * y * y);
  return y > 0.0 ? -1.0 / (eps * eps * y) : 0.0;
}

}  // namespace fem_cloth::friction

namespace fem_cloth::mollifier {

/// e(c) = (2 - c/epsX) c/epsX for c < epsX, else 1, with c = |ea x eb|^2 (IPC section 4.3).
inline double value(double c, double epsX) {
  if (c >= epsX) return 1.0;
  const double r = c / epsX;
  return (2.0 - r) * r;
}
inline double first(double c, double epsX) {
  if (c >= epsX) return 0.0;
  return 2.0 / epsX - 2.0 * c / (epsX * epsX);
}
inline double second(double c, double epsX) {
  if (c >= epsX) return 0.0;
  return -2.0 / (epsX * epsX);
}

}  // namespace fem_cloth::mollifier
