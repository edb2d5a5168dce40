// Pieces of a substep that every stepper shares: pins moved along their path, the energy mass
// damping removes (the implicit steppers' MassDampingTerm too), and the refusal of a non-finite
// state. Inline so that each stepper's arithmetic is exactly what it was when written out in place.
#pragma once

#include <string>

#include "fem_cloth/core/contact/obstacle_set.h"
#include "fem_cloth/core/integrators/integrator.h"

namespace fem_cloth {

/// A pinned DOF at the end of a substep: it moves on the straight line from `x` to its
/// end-of-step `target`, 1 / `remaining` of the way (`remaining` counts the substeps left,
/// this one included), so that it reaches the target at the end of the step (integrator.h).
inline double pinAfterSubstep(double x, double target, int remaining) {
  return x + (target - x) / remaining;
}

/// The work a pin does on its DOF in a substep that moves it by dx and changes its velocity from
/// vStart to vEnd = dx / h (symplectic Euler, backward Euler), when the DOF's equation of motion
/// holds the pin force f = m (vEnd - vStart) / h - (the other forces). f dx books m dv vEnd for
/// the inertia, the kinetic energy changes by m dv (vStart + vEnd) / 2: f dx overstates it by
/// m dv^2 / 2, which is negligible while the pin moves smoothly but is all of it when the pin
/// starts or stops at once (a target far from its vertex: twice the kinetic energy the jump gave,
/// and nothing for the one it took away when the pin stopped). The work-energy theorem for the
/// pinned DOF books the kinetic energy exactly: f dx - m dv^2 / 2.
inline double pinWorkInSubstep(double force, double dx, double mass, double vStart, double vEnd) {
  const double dv = vEnd - vStart;
  return force * dx - 0.5 * mass * dv * dv;
}

/// The energy mass-proportional damping -alpha M v removes in a substep of size h ending at
/// velocity v: its dissipation rate alpha v^T M v times h (J).
inline double massDampingDissipation(double h, double alpha, const VectorX& v, const VectorX& mass) {
  return h * alpha * v.dot(mass.cwiseProduct(v));
}

/// Adds massDampingDissipation to the report; nothing when alpha is zero.
inline void addMassDampingDissipation(double h, double alpha, const VectorX& v, const VectorX& mass,
                                      StepReport& report) {
  if (alpha > 0.0) report.dissipated += massDampingDissipation(h, alpha, v, mass);
}

/// A substep's contact statistics into the step's report: the contacts, the smallest distance
/// and the barriers' stored energy at its end; the obstacles' work and the friction's
/// dissipation added.
inline void recordContact(const ContactStats& stats, StepReport& report) {
  report.contacts = stats.contacts;
  report.minContactDistance = stats.minDistance;
  report.contactWork += stats.work;
  report.dissipated += stats.dissipated;
  report.contactEnergy = stats.stored;
  if (stats.boxDepth > report.boxDepth) {
    report.boxDepth = stats.boxDepth;
    report.boxDepthWhere = stats.boxDepthWhere;
  }
  if (!stats.crossing.empty() && report.ok) {
    report.ok = false;
    report.error = stats.crossing;
  }
}

/// True when positions and velocities are finite; otherwise the report fails, saying which
/// integrator lost the state (the caller returns it and the simulator restores the state). The
/// name is a C string, made into a std::string only on failure: steps allocate nothing.
inline bool stateIsFinite(const State& state, const char* integrator, StepReport& report) {
  if (state.x.allFinite() && state.v.allFinite()) return true;
  report.ok = false;
  report.error = std::string(integrator) + ": the state became non-finite";
  return false;
}

}  // namespace fem_cloth
