// The check of per-vertex access (EnergyTerm::vertexDerivatives, PotentialTerm's) shared by
// test_vertex_access.cpp and test_potential.cpp: at every vertex, the force and 3 x 3 Hessian
// block against
//  - central differences of the term's energy (the force) and of its gradient (the block):
//    independent of the per-vertex code and of the assembled Hessian;
//  - the vertex's row of the assembled gradient and its diagonal block of the assembled exact
//    and projected Hessians (the same model evaluated element by element the other way round).
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <functional>
#include <iostream>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "fem_cloth/core/energy_term.h"
#include "fem_cloth/core/potential/potential_term.h"
#include "fem_cloth/core/sparse_hessian.h"

namespace fem_cloth::test {

// A term as the checks see it.
struct Probe {
  std::string name;
  int dim = 3;
  std::function<double(const VectorX&)> energy;
  std::function<VectorX(const VectorX&)> gradient;
  std::function<Eigen::MatrixXd(const VectorX&, HessianMode)> hessian;  // dense, assembled
  std::function<bool(const VectorX&, Index, HessianMode, VertexDerivatives&)> vertex;
  // Whether the projected block must equal the assembled projected Hessian's (it projects per
  // element the way the per-vertex path does).
  bool projectedIsAssembled = true;
  // Whether the exact block is the exact Hessian's (else, for the contact, the assembled PSD
  // one's, and the block is not compared with differences of the gradient).
  bool exactBlocks = true;
  double step = 0.0;  // m, of the differences; 0: 1e-6 of the span of x
  double blockTolerance = 1e-5;  // of the block against the differences of the gradient (relative)
};

// A term of the Model (Request = EvalRequest) or of the incremental potential (TermRequest),
// its Hessian assembled into `pattern`; with dofMasses (per DOF), a potential's term's
// mass-proportional Hessian k M (which the potential adds, not the term) on its diagonal.
// Prepares the term's per-vertex access.
template <class Request, class Term>
Probe probeOf(Term& term, std::shared_ptr<SparseHessian> pattern, int dim,
              const VectorX* dofMasses = nullptr) {
  term.prepareVertexAccess();
  Probe p;
  p.name = term.name();
  p.dim = dim;
  p.energy = [&term](const VectorX& x) { return term.evaluate(x, Request{}).energy; };
  p.gradient = [&term](const VectorX& x) {
    VectorX g = VectorX::Zero(x.size());
    Request r;
    r.energy = false;
    r.gradient = &g;
    term.evaluate(x, r);
    return g;
  };
  p.hessian = [&term, pattern, dofMasses](const VectorX& x, HessianMode mode) -> Eigen::MatrixXd {
    pattern->setZero();
    Request r;
    r.energy = false;
    r.hessian = pattern.get();
    r.hessianMode = mode;
    // A potential's term may couple vertices the pattern does not (self-contact): triplets.
    std::vector<Eigen::Triplet<double>> outside;
    if constexpr (std::is_same_v<Request, TermRequest>) r.outside = &outside;
    term.evaluate(x, r);
    Eigen::SparseMatrix<double> extra(x.size(), x.size());
    extra.setFromTriplets(outside.begin(), outside.end());
    Eigen::MatrixXd dense = Eigen::MatrixXd(pattern->matrix()) + Eigen::MatrixXd(extra);
    if constexpr (std::is_same_v<Request, TermRequest>) {
      if (dofMasses != nullptr) dense.diagonal() += term.massProportionalHessian() * *dofMasses;
    }
    return dense;
  };
  p.vertex = [&term](const VectorX& x, Index v, HessianMode mode, VertexDerivatives& out) {
    return term.vertexDerivatives(x, v, mode, out);
  };
  return p;
}

inline double symmetricMinEigenvalue(const Eigen::Matrix3d& A) {
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(0.5 * (A + A.transpose())).eigenvalues()[0];
}

// The largest differences over all vertices, each relative to the size of what it compares.
// Returns how much the projection changed a block (relative): zero where the term is convex at x.
inline double checkVertexAccess(const Probe& p, const VectorX& x) {
  const int d = p.dim;
  const Index n = x.size() / d;
  const VectorX g = p.gradient(x);
  const Eigen::MatrixXd H = p.hessian(x, HessianMode::Exact);
  const Eigen::MatrixXd Hp = p.hessian(x, HessianMode::Projected);
  const double fScale = std::max(g.cwiseAbs().maxCoeff(), 1e-300);
  const double hScale = std::max(H.cwiseAbs().maxCoeff(), 1e-300);
  const double span = (x.maxCoeff() - x.minCoeff());
  const double step = p.step > 0.0 ? p.step : 1e-6 * span;
  double forceFd = 0.0, forceRow = 0.0, blockFd = 0.0, blockExact = 0.0, blockProjected = 0.0;
  double negative = 0.0, projection = 0.0;
  for (Index v = 0; v < n; ++v) {
    VertexDerivatives exact, projected;
    const bool servedExact = p.vertex(x, v, HessianMode::Exact, exact);
    const bool servedProjected = p.vertex(x, v, HessianMode::Projected, projected);
    EXPECT_TRUE(servedExact && servedProjected) << p.name << " vertex " << v;
    if (!servedExact || !servedProjected) return 0.0;
    projection = std::max(projection, (projected.hessian - exact.hessian).cwiseAbs().maxCoeff());
    for (int a = 0; a < 3; ++a) {
      if (a >= d) {
        // A planar mesh uses the top-left d x d only.
        EXPECT_EQ(exact.force[a], 0.0) << p.name;
        EXPECT_EQ(exact.hessian.row(a).norm() + exact.hessian.col(a).norm(), 0.0) << p.name;
        continue;
      }
      VectorX xp = x, xm = x;
      xp[d * v + a] += step;
      xm[d * v + a] -= step;
      forceFd = std::max(forceFd, std::abs(exact.force[a] + (p.energy(xp) - p.energy(xm)) / (2 * step)));
      forceRow = std::max(forceRow, std::abs(exact.force[a] + g[d * v + a]));
      const VectorX column = (p.gradient(xp) - p.gradient(xm)) / (2 * step);
      for (int b = 0; b < d; ++b) {
        if (p.exactBlocks) blockFd = std::max(blockFd, std::abs(exact.hessian(b, a) - column[d * v + b]));
        blockExact = std::max(blockExact, std::abs(exact.hessian(b, a) - H(d * v + b, d * v + a)));
        if (p.projectedIsAssembled) {
          blockProjected =
              std::max(blockProjected, std::abs(projected.hessian(b, a) - Hp(d * v + b, d * v + a)));
        }
      }
    }
    negative = std::min(negative, symmetricMinEigenvalue(projected.hessian));
  }
  std::cout << p.name << " (" << d << "D): force vs differences of E " << forceFd / fScale
            << ", vs gradient row " << forceRow / fScale << "; block vs differences of the gradient "
            << blockFd / hScale << ", vs exact Hessian " << blockExact / hScale
            << ", projected vs projected Hessian " << blockProjected / hScale
            << ", most negative projected eigenvalue " << negative / hScale
            << "; the projection changed blocks by " << projection / hScale << " (relative)\n";
  EXPECT_LT(forceFd, 1e-6 * fScale) << p.name;
  EXPECT_LT(forceRow, 1e-12 * fScale) << p.name;
  EXPECT_LT(blockFd, p.blockTolerance * hScale) << p.name;
  EXPECT_LT(blockExact, 1e-12 * hScale) << p.name;
  EXPECT_LT(blockProjected, 1e-12 * hScale) << p.name;
  EXPECT_GT(negative, -1e-12 * hScale) << p.name;
  return projection / hScale;
}

}  // namespace fem_cloth::test
