// Continuous collision detection for the line search of the implicit steppers: how far along a
// displacement the positions can move without any distance reaching zero.
//
// Additive CCD (Li, Kaufman & Jiang, "Codimensional Incremental Potential Contact", SIGGRAPH
// 2021, section 5 and Algorithm 1): a distance that is Lipschitz in the step parameter t with a
// known constant l_p cannot drop faster than l_p per unit t, so advancing t by a fraction of
// d(t) / l_p at a time never steps over a contact. The first advance keeps a distance of at least
// s d(0) (s = kRescaling); the search stops before the distance falls below s d(0), which keeps
// every step away from zero distance, where the barrier is infinite. It works for any distance
// with a Lipschitz bound: the obstacles' exact signed distances (constant 1 in the point's
// motion) and the point-triangle and edge-edge distances (the largest motion of each side, after
// removing the common mean, Li et al. 2021, eq. 5).
#pragma once

#include <Eigen/Core>
#include <algorithm>

namespace fem_cloth::ccd {

/// s: a step keeps at least this fraction of the distance at its start.
constexpr double kRescaling = 0.1;
constexpr int kMaxIterations = 10000;

/// The largest t in [0, tMax] found by additive CCD for a distance d(t) (m) with d(0) = d0 > 0
/// and Lipschitz constant lp (m per unit t). 0 if d0 <= 0; tMax if lp is zero.
template <class DistanceAt>
double additive(DistanceAt distanceAt, double d0, double lp, double tMax) {
  if (!(d0 > 0.0)) return 0.0;
  if (!(lp > 0.0)) return tMax;
  const double gap = kRescaling * d0;
  double t = 0.0;
  double advance = (1.0 - kRescaling) * d0 / lp;
  for (int it = 0; it < kMaxIterations; ++it) {
    const double next = t + advance;
    if (next >= tMax) return tMax;
    const double d = distanceAt(next);
    // The first advance keeps at least s d0 by the Lipschitz bound; later ones may come closer.
    if (it > 0 && d < gap) return t;
    t = next;
    advance = 0.9 * d / lp;
  }
  return t;
}

/// True if a distance d(t), t in [0, 1], Lipschitz with constant lp, comes within `gap` of zero
/// (exact conservative advancement; an undecided grazing path counts as coming within).
template <class DistanceAt>
bool comesWithin(DistanceAt distanceAt, double d0, double lp, double gap) {
  double t = 0.0, d = d0;
  for (int it = 0; it < 64; ++it) {
    if (d <= gap) return true;
    if (!(lp > 0.0)) return false;
    t += (d - gap) / lp;
    if (t >= 1.0) return false;
    d = distanceAt(t);
  }
  return true;
}

/// Additive CCD of the point-triangle (p, t0, t1, t2) and the edge-edge (a0, a1, b0, b1) pairs
/// moving by dx over t in [0, tMax]: the largest collision-free t.
double pointTriangle(const Eigen::Matrix<double, 3, 4>& x, const Eigen::Matrix<double, 3, 4>& dx,
                     double tMax);
double edgeEdge(const Eigen::Matrix<double, 3, 4>& x, const Eigen::Matrix<double, 3, 4>& dx,
                double tMax);

}  // namespace fem_cloth::ccd
