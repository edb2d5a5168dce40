// The heavy inextensible elastica: a cantilever strip, clamped horizontally at one end, bending
// under its own weight. The reference of Peirce's cantilever test (F. T. Peirce, "The handle of
// cloth as a measurable quantity", J. Textile Inst. 21, T377-T416, 1930; ASTM D1388), solved
// here independently of the simulator.
//
// With theta(s) the tangent's angle below the horizontal at arc length s, B the bending rigidity
// and w the weight per unit length (both per unit width for a strip), the moment balance is
//   B theta'' = -w (l - s) cos(theta),   theta(0) = 0 (clamped),   theta'(l) = 0 (free tip).
// In sigma = s / l it depends on gamma = w l^3 / B alone:
//   theta'' = -gamma (1 - sigma) cos(theta).
// Solved by shooting on theta'(0) (bracketed in [0, gamma / 2], bisection) with classical RK4.
#pragma once

namespace fem_cloth::validate {

struct ElasticaSolution {
  double gamma = 0.0;
  double tipDrop = 0.0;        ///< vertical drop of the tip / l
  double tipReach = 0.0;       ///< horizontal distance of the tip from the clamp / l
  double rootCurvature = 0.0;  ///< theta'(0) l
  double tipAngle = 0.0;       ///< theta(l), rad
  double chordAngle = 0.0;     ///< atan(tipDrop / tipReach), rad: the angle Peirce's test reads
  bool ok = false;             ///< the shooting converged (|theta'(1)| < 1e-12 gamma)
};

/// The elastica for gamma = w l^3 / B >= 0, integrated with `steps` RK4 steps.
ElasticaSolution heavyElastica(double gamma, int steps = 4000);

/// Peirce's bending length c = (B / w)^(1/3) (m) from the rigidity B (N m) and the weight per
/// unit area w (N / m^2).
double peirceBendingLength(double rigidity, double weightPerArea);

/// The gamma at which the elastica's tip chord makes `chordAngle` (rad, in (0, pi/2)) with the
/// horizontal: how a lab reads B = w l^3 / gamma from a strip's overhang l and tip angle
/// (bisection; the chord angle grows with gamma). ASTM D1388 fixes the angle at 41.5 deg, where
/// gamma = 8 (c = l / 2).
double elasticaGammaForChordAngle(double chordAngle);

/// The gamma at which the elastica's tip drops by `tipDrop` (/ l, in (0, 1)): the rigidity read
/// back from a strip's tip drop instead of its angle (the drop grows with gamma). Where the strip
/// hangs nearly vertical (gamma 20: a 5 % change of B moves the drop by 1 %) this reading shows a
/// stiffness error that the drop itself hides.
double elasticaGammaForTipDrop(double tipDrop);

}  // namespace fem_cloth::validate
