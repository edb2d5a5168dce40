#include "fem_cloth/core/integrators/acceptance.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "fem_cloth/core/integrators/integrator.h"
#include "fem_cloth/core/model.h"

namespace fem_cloth {

namespace {

// a replaces b as the worse residual: larger, or NaN (which stays once seen).
bool worse(double a, double b, bool bMeasured) {
  if (!bMeasured) return true;
  if (std::isnan(b)) return false;
  return !(a <= b);
}

}  // namespace

void ForceResidual::merge(const ForceResidual& other) {
  if (other.dof < 0) return;
  const double largestSoFar = std::max(largest, other.largest);
  if (worse(other.relative, relative, dof >= 0)) *this = other;
  largest = std::isnan(other.largest) ? other.largest : largestSoFar;
}

ForceResidual measureResidual(const VectorX& residual, const VectorX& mass,
                              const VectorX& externalForce, const std::vector<char>& pinned,
                              const VectorX& vStart, const VectorX& vEnd, double h,
                              double acceleration) {
  ForceResidual out;
  for (Index i = 0; i < residual.size(); ++i) {
    if (pinned[i]) continue;
    const double force = std::abs(residual[i]);
    const double speed = std::max(std::abs(vStart[i]), std::abs(vEnd[i]));
    const double scale = mass[i] * (acceleration + speed / h) + std::abs(externalForce[i]);
    const double relative = force / scale;
    out.largest = std::max(out.largest, force);
    if (std::isnan(force)) out.largest = force;
    if (worse(relative, out.relative, out.dof >= 0)) {
      out.relative = relative;
      out.force = force;
      out.scale = scale;
      out.dof = i;
    }
  }
  return out;
}

double truncationEstimate(const SubstepMotion& motion, Index vertex, int dim) {
  const VectorX& v0 = *motion.vStart;
  const VectorX& v1 = *motion.vEnd;
  double sum = 0.0;
  for (int k = 0; k < dim; ++k) {
    const Index i = dim * vertex + k;
    const double change = motion.vBefore != nullptr ? v1[i] - 2.0 * v0[i] + (*motion.vBefore)[i]
                                                    : v1[i] - v0[i];
    sum += change * change;
  }
  const double factor = motion.vBefore != nullptr ? 2.0 / 9.0 : 0.5;
  return factor * motion.h * std::sqrt(sum);
}

void DisplacementError::merge(const DisplacementError& other) {
  if (!other.measured()) return;
  const double largestSoFar = std::max(largest, other.largest);
  const double energyRatio = energy / energyTolerance, otherEnergyRatio = other.energy / other.energyTolerance;
  const double energySoFar = energy, energyToleranceSoFar = energyTolerance;
  const bool hadOne = measured();
  if (worse(other.relative, relative, hadOne)) *this = other;
  largest = std::isnan(other.largest) ? other.largest : largestSoFar;
  // The energy part: the worse ratio of the two, wherever it is.
  if (hadOne && !worse(otherEnergyRatio, energyRatio, true)) {
    energy = energySoFar;
    energyTolerance = energyToleranceSoFar;
  } else {
    energy = other.energy;
    energyTolerance = other.energyTolerance;
  }
}

void DisplacementError::scale(double factor) {
  if (!measured()) return;
  if (std::isinf(factor)) {
    relative = std::numeric_limits<double>::infinity();
    return;
  }
  relative *= factor;
  error *= factor;
  largest *= factor;
  energy *= factor;
}

double remainingErrorFactor(double correction, double moved) {
  if (!(moved > 0.0)) return 1.0;
  const double theta = correction / moved;
  return theta < 1.0 ? 1.0 / (1.0 - theta) : std::numeric_limits<double>::infinity();
}

DisplacementError measureDisplacementError(const VectorX& dx, const SubstepMotion& motion,
                                           const std::vector<char>& pinned, int dim,
                                           const DisplacementTolerance& tolerance) {
  DisplacementError out;
  const VectorX& x0 = *motion.xStart;
  const VectorX& x1 = *motion.xEnd;
  const Index vertices = dx.size() / dim;
  for (Index v = 0; v < vertices; ++v) {
    if (pinned[dim * v]) continue;
    double error2 = 0.0, motion2 = 0.0;
    for (int k = 0; k < dim; ++k) {
      const Index i = dim * v + k;
      error2 += dx[i] * dx[i];
      motion2 += (x1[i] - x0[i]) * (x1[i] - x0[i]);
    }
    const double error = std::sqrt(error2), moved = std::sqrt(motion2);
    const double tau = truncationEstimate(motion, v, dim);
    const double bound = std::min(tolerance.ratio * tau, tolerance.cap * moved) + tolerance.floor;
    const double relative = error / bound;
    out.largest = std::isnan(error) ? error : std::max(out.largest, error);
    if (worse(relative, out.relative, out.measured())) {
      out.relative = relative;
      out.error = error;
      out.tolerance = bound;
      out.truncation = tau;
      out.motion = moved;
      out.vertex = v;
    }
  }
  return out;
}

Status StepAcceptance::converged(const StepReport& report, int dim) const {
  const DisplacementError& e = report.displacement;
  if (e.measured()) {
    if (e.within()) return Status::success();
    const DisplacementTolerance& t = settings_.displacement;
    std::ostringstream msg;
    if (e.relative <= 1.0) {
      msg << "not converged: the correction the solver's matrix makes of its unbalanced force would change the "
          << "step's energy by " << e.energy << " J, above its tolerance " << e.energyTolerance << " J ("
          << t.ratio << " x the energy test's bound); largest unbalanced force " << report.unbalanced.largest
          << " N (a smaller dt or more integrator.substeps may help)";
      return Error{msg.str()};
    }
    msg << "not converged: vertex " << e.vertex << " is left with a displacement error of " << e.error
        << " m (the correction the solver's matrix makes of its unbalanced force), above its tolerance "
        << e.tolerance << " m (" << t.ratio << " x the step's truncation error there, " << e.truncation
        << " m, at most " << 100.0 * t.cap << " % of its motion " << e.motion
        << " m, plus the floor); largest unbalanced force " << report.unbalanced.largest
        << " N (a smaller dt or more integrator.substeps may help)";
    return Error{msg.str()};
  }
  const ForceResidual& r = report.unbalanced;
  if (r.dof < 0 || r.relative <= settings_.forceTolerance) return Status::success();
  std::ostringstream msg;
  msg << "not converged: vertex " << r.dof / dim << " (" << "xyz"[r.dof % dim]
      << ") is left with an unbalanced force of " << r.force << " N, " << 100.0 * r.relative
      << " % of its force scale " << r.scale << " N (weight, inertia and load; at most "
      << 100.0 * settings_.forceTolerance
      << " % is accepted; a smaller dt or more integrator.substeps may help)";
  return Error{msg.str()};
}

Status StepAcceptance::energyConserved(const EnergyStep& energy, double tolerance,
                                       double sizeScale) const {
  if (!settings_.energy) return Status::success();
  const double scale = std::max({sizeScale, energy.held, std::abs(energy.work()), 1e-12});
  const double created = energy.created();
  // A non-finite energy is never accepted (with it the scale would be infinite too).
  if (std::isfinite(energy.end) && std::isfinite(scale) && created <= tolerance * scale) {
    return Status::success();
  }
  std::ostringstream msg;
  msg << "energy created: the step put " << created
      << " J into the cloth beyond the work done on it and the energy damping removed (from "
      << energy.start << " J to " << energy.end << " J with " << energy.work() << " J of work; bound "
      << tolerance * scale << " J, " << 100.0 * tolerance << " % of the energy scale " << scale
      << " J)";
  return Error{msg.str()};
}

Status StepAcceptance::runEnergyConserved(double createdBefore, const EnergyStep& energy,
                                          double runScale) const {
  if (!settings_.energy) return Status::success();
  const double created = createdBefore + energy.created();
  const double bound = settings_.runEnergyTolerance * runScale;
  if (created <= bound) return Status::success();
  std::ostringstream msg;
  msg << "energy created over the run: with this step the cloth would hold " << created
      << " J more than the work done on it since the start less what damping removed (" << energy.created()
      << " J of it in this step; bound " << bound << " J, " << 100.0 * settings_.runEnergyTolerance
      << " % of the run's energy scale " << runScale << " J)";
  return Error{msg.str()};
}

Status StepAcceptance::valid(Model& model, const VectorX& x) const {
  if (!settings_.validity || !model.hasValidityRanges()) return Status::success();
  const Model::TermValidity v = model.validity(x);
  if (v.term < 0 || v.validity.ok()) return Status::success();
  std::ostringstream msg;
  msg << "outside the validity range: element " << v.validity.element << " of "
      << model.term(static_cast<std::size_t>(v.term)).name() << " has a " << v.validity.what
      << " of " << v.validity.measure << ", above the model's limit " << v.validity.limit << " ("
      << v.validity.advice << ")";
  return Error{msg.str()};
}

}  // namespace fem_cloth
