#include "fem_cloth/validate/statics.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "fem_cloth/core/integrators/linear_solver.h"

namespace fem_cloth::validate {

namespace {

struct Problem {
  Model& model;
  const std::vector<char>& pinned;  // per DOF
  VectorX load;                     // the current load increment's total force (N)

  /// Phi = E - f . x; +inf outside the model's domain.
  double potential(const VectorX& x) const {
    const EvalResult r = model.evaluate(x, EvalRequest{});
    return r.inDomain ? r.energy - load.dot(x) : kInfiniteEnergy;
  }

  /// dPhi/dx with the pinned DOFs zeroed.
  VectorX residual(const VectorX& x) const {
    VectorX g = VectorX::Zero(x.size());
    model.evaluate(x, EvalRequest{false, &g, nullptr, HessianMode::Projected});
    g -= load;
    for (Eigen::Index i = 0; i < g.size(); ++i) {
      if (pinned[static_cast<std::size_t>(i)]) g[i] = 0.0;
    }
    return g;
  }

  /// The largest diagonal entry of the projected Hessian on a free DOF (N/m): the stiffness that
  /// turns a position's round-off into a force's.
  double largestStiffness(const VectorX& x, SparseHessian& H) const {
    H.setZero();
    model.evaluate(x, EvalRequest{false, nullptr, &H, HessianMode::Projected});
    double largest = 0.0;
    for (Index i = 0; i < H.matrix().rows(); ++i) {
      if (!pinned[static_cast<std::size_t>(i)]) largest = std::max(largest, std::abs(H.values()[H.diagonalOffset(i)]));
    }
    return largest;
  }

  /// The projected Hessian with pinned rows and columns replaced by the identity, plus
  /// lambda * mean(diagonal) on the free diagonal.
  void dampedHessian(const VectorX& x, double lambda, SparseHessian& H) const {
    H.setZero();
    model.evaluate(x, EvalRequest{false, nullptr, &H, HessianMode::Projected});
    SparseHessian::Matrix& A = H.matrix();
    double diagonal = 0.0;
    for (Index i = 0; i < A.rows(); ++i) diagonal += std::abs(H.values()[H.diagonalOffset(i)]);
    diagonal = std::max(diagonal / static_cast<double>(A.rows()), 1e-300);
    for (int c = 0; c < A.outerSize(); ++c) {
      for (SparseHessian::Matrix::InnerIterator it(A, c); it; ++it) {
        const bool fixed = pinned[static_cast<std::size_t>(it.row())] || pinned[static_cast<std::size_t>(c)];
        if (fixed) it.valueRef() = it.row() == c ? 1.0 : 0.0;
      }
    }
    for (Index i = 0; i < A.rows(); ++i) {
      if (!pinned[static_cast<std::size_t>(i)]) H.values()[H.diagonalOffset(i)] += lambda * diagonal;
    }
  }
};

double maxAbs(const VectorX& v) { return v.size() == 0 ? 0.0 : v.cwiseAbs().maxCoeff(); }

}  // namespace

StaticResult solveStatics(Simulation& sim, const StaticSettings& settings) {
  StaticResult result;
  Simulator& simulator = *sim.simulator;
  Model& model = simulator.model();
  const int d = model.dim();
  const Index n = model.numDofs();
  std::vector<char> pinned(static_cast<std::size_t>(n), 0);
  VectorX x = simulator.state().x;
  for (Index v : simulator.pinnedVertices()) {
    const Eigen::Vector3d target = simulator.pinTarget(v);
    for (int k = 0; k < d; ++k) {
      pinned[static_cast<std::size_t>(d * v + k)] = 1;
      x[d * v + k] = target[k];
    }
  }
  VectorX totalLoad = simulator.externalForce();
  for (Index i = 0; i < model.numVertices(); ++i) {
    for (int k = 0; k < d; ++k) totalLoad[d * i + k] += model.vertexMasses()[i] * simulator.settings().gravity[k];
  }
  double loadScale = 0.0;
  for (Index i = 0; i < n; ++i) {
    if (!pinned[static_cast<std::size_t>(i)]) loadScale = std::max(loadScale, std::abs(totalLoad[i]));
  }
  if (!(loadScale > 0.0)) loadScale = 1.0;
  Problem problem{model, pinned, VectorX()};
  SparseHessian& H = model.hessianPattern();
  // Forces cannot be resolved below the round-off of the positions times the stiffness
  // (eps |x| K per DOF): a stiff membrane under a light load, or an energy that cancels large
  // terms (the quadratic bending model's sum K x), sets a floor above 1e-8 of the load.
  const double floor = 10.0 * std::numeric_limits<double>::epsilon() * maxAbs(x) *
                       problem.largestStiffness(x, H) / loadScale;
  result.tolerance = std::max(settings.tolerance, floor);
  std::unique_ptr<LinearSolver> solver = makeLinearSolver(LinearSolverSettings{}, n);
  const int steps = std::max(settings.loadSteps, 1);
  for (int step = 1; step <= steps; ++step) {
    problem.load = totalLoad * (static_cast<double>(step) / steps);
    // Intermediate load steps only need to be close enough to start the next one.
    const double tolerance = step == steps ? result.tolerance : std::max(result.tolerance, 1e-6);
    double lambda = 1e-6;
    double phi = problem.potential(x);
    if (!std::isfinite(phi)) {
      result.error = "the start state is outside the model's domain";
      return result;
    }
    for (int it = 0;; ++it) {
      const VectorX g = problem.residual(x);
      result.residual = maxAbs(g) / loadScale;
      if (result.residual <= tolerance) break;
      if (it >= settings.maxIterations) {
        result.error = "no equilibrium after " + std::to_string(it) + " iterations at load step " +
                       std::to_string(step) + " (residual " + numberText(result.residual) + ")";
        return result;
      }
      ++result.iterations;
      problem.dampedHessian(x, lambda, H);
      VectorX dx = VectorX::Zero(n);
      if (!solver->compute(H.matrix()) || !solver->solve(-g, dx) || !dx.allFinite()) {
        lambda *= 10.0;
        continue;
      }
      const VectorX trial = x + dx;
      const double phiTrial = problem.potential(trial);
      // Accept a decrease of Phi, or (at round-off level of Phi) a smaller residual.
      const double roundOff = 1e-12 * (std::abs(phi) + std::abs(problem.load.dot(x)) + 1e-300);
      if (std::isfinite(phiTrial) &&
          (phiTrial < phi || (phiTrial <= phi + roundOff && maxAbs(problem.residual(trial)) < maxAbs(g)))) {
        x = trial;
        phi = phiTrial;
        lambda = std::max(lambda * 0.1, 1e-14);
      } else {
        lambda = std::min(lambda * 10.0, 1e12);
      }
    }
  }
  if (Status s = simulator.setInitialState(x); !s) {
    result.error = s.error();
    return result;
  }
  result.converged = true;
  return result;
}

}  // namespace fem_cloth::validate
