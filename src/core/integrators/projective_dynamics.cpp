#include "fem_cloth/core/integrators/projective_dynamics.h"

#include <algorithm>
#include <cmath>

namespace fem_cloth {

bool ProjectiveDynamics::prepare(const StepInput& input, double h, std::string* error) {
  Model& model = *input.model;
  const Index n = model.numVertices();
  const int d = model.dim();
  if (!haveLaplacian_) {
    std::vector<Eigen::Triplet<double>> triplets;
    for (std::size_t t = 0; t < model.numTerms(); ++t) {
      EnergyTerm& term = model.term(t);
      if (!term.supportsProjective()) {
        *error = "projective_dynamics minimises the ARAP membrane (material.model: arap) and "
                 "quadratic bending on cloth (dim 3); energy term '" + term.name() +
                 "' has no projective form";
        return false;
      }
      term.appendProjectiveMatrix(&triplets);
    }
    laplacian_.resize(n, n);
    laplacian_.setFromTriplets(triplets.begin(), triplets.end());
    haveLaplacian_ = true;
  }
  // Pins hold whole vertices: the free system is over vertices.
  const std::vector<char>& pinned = *input.pinned;
  pinnedVertices_.resize(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) pinnedVertices_[i] = pinned[d * i];
  if (pinnedVertices_ == factorisedFor_ && h == factorisedH_) return true;
  const std::vector<char>& pinnedVertices = pinnedVertices_;

  freeIndex_.assign(n, -1);
  freeVertices_.clear();
  for (Index i = 0; i < n; ++i) {
    if (!pinnedVertices[i]) {
      freeIndex_[i] = static_cast<Index>(freeVertices_.size());
      freeVertices_.push_back(i);
    }
  }
  std::vector<Index> pinnedIndex(n, -1);
  Index numPinned = 0;
  for (Index i = 0; i < n; ++i) {
    if (pinnedVertices[i]) pinnedIndex[i] = numPinned++;
  }
  const double inertia = (1.0 + h * input.damping.massProportional) / (h * h);
  std::vector<Eigen::Triplet<double>> ff, fp;
  for (Index j = 0; j < n; ++j) {
    for (Matrix::InnerIterator it(laplacian_, j); it; ++it) {
      const Index i = static_cast<Index>(it.row());
      if (freeIndex_[i] < 0) continue;
      if (freeIndex_[j] >= 0) {
        ff.emplace_back(freeIndex_[i], freeIndex_[j], it.value());
      } else {
        fp.emplace_back(freeIndex_[i], pinnedIndex[j], it.value());
      }
    }
  }
  const Index nf = static_cast<Index>(freeVertices_.size());
  for (Index k = 0; k < nf; ++k) {
    ff.emplace_back(k, k, model.vertexMasses()[freeVertices_[k]] * inertia);
  }
  systemFree_.resize(nf, nf);
  systemFree_.setFromTriplets(ff.begin(), ff.end());
  couplingFreePinned_.resize(nf, numPinned);
  couplingFreePinned_.setFromTriplets(fp.begin(), fp.end());
  solver_.compute(systemFree_);
  if (solver_.info() != Eigen::Success) {
    *error = "projective_dynamics: the system matrix could not be factorised";
    return false;
  }
  ++factorisations_;
  // Keep the factor L (column-major, diagonal first in each column) and the fill-reducing
  // permutation (P A P^T = L L^T) for solveAllCoordinates.
  const Matrix& L = solver_.matrixL().nestedExpression();
  factorOuter_.assign(L.outerIndexPtr(), L.outerIndexPtr() + L.outerSize() + 1);
  factorInner_.assign(L.innerIndexPtr(), L.innerIndexPtr() + L.nonZeros());
  factorValues_.assign(L.valuePtr(), L.valuePtr() + L.nonZeros());
  permutation_.assign(solver_.permutationP().indices().data(),
                      solver_.permutationP().indices().data() + nf);
  work_.resize(nf, d - 1);
  tailWork_.resize(nf);
  factorisedFor_ = pinnedVertices_;
  factorisedH_ = h;
  rhsFree_.resize(nf, d);
  solFree_.resize(nf, d);
  pinnedPositions_.resize(numPinned, d);
  return true;
}

namespace {

// Forward (L y = b) and backward (L^T z = y) substitution on D interleaved right-hand sides,
// y[D*i + c]; column j of the CSC factor L starts with its diagonal. D is a template parameter
// so that the inner loops over coordinates unroll.
template <int D>
void substitute(Index n, const int* outer, const int* inner, const double* value, double* y) {
  for (Index j = 0; j < n; ++j) {
    double* yj = y + D * j;
    const double inv = 1.0 / value[outer[j]];
    for (int c = 0; c < D; ++c) yj[c] *= inv;
    for (int k = outer[j] + 1; k < outer[j + 1]; ++k) {
      double* yi = y + D * inner[k];
      const double l = value[k];
      for (int c = 0; c < D; ++c) yi[c] -= l * yj[c];
    }
  }
  for (Index j = n - 1; j >= 0; --j) {
    double* yj = y + D * j;
    double acc[D];
    for (int c = 0; c < D; ++c) acc[c] = yj[c];
    for (int k = outer[j] + 1; k < outer[j + 1]; ++k) {
      const double* yi = y + D * inner[k];
      const double l = value[k];
      for (int c = 0; c < D; ++c) acc[c] -= l * yi[c];
    }
    const double inv = 1.0 / value[outer[j]];
    for (int c = 0; c < D; ++c) yj[c] = acc[c] * inv;
  }
}

}  // namespace

void ProjectiveDynamics::solveAllCoordinates() {
  const Index nf = static_cast<Index>(permutation_.size());
  const int d = static_cast<int>(rhsFree_.cols());
  const int* outer = factorOuter_.data();
  const int* inner = factorInner_.data();
  const double* value = factorValues_.data();
  // Two independent solves, on two threads for large systems: the first d - 1 coordinates
  // interleaved, the last alone. Each is the same arithmetic whatever the number of threads.
  double* head = work_.data();   // nf x (d - 1), row-major
  double* tail = tailWork_.data();  // nf
  for (Index i = 0; i < nf; ++i) {
    for (int c = 0; c + 1 < d; ++c) head[(d - 1) * permutation_[i] + c] = rhsFree_(i, c);
    tail[permutation_[i]] = rhsFree_(i, d - 1);
  }
#pragma omp parallel sections if (nf >= kParallelElementThreshold)
  {
#pragma omp section
    {
      if (d == 3) {
        substitute<2>(nf, outer, inner, value, head);
      } else {
        substitute<1>(nf, outer, inner, value, head);
      }
    }
#pragma omp section
    substitute<1>(nf, outer, inner, value, tail);
  }
  for (Index i = 0; i < nf; ++i) {
    for (int c = 0; c + 1 < d; ++c) solFree_(i, c) = head[(d - 1) * permutation_[i] + c];
    solFree_(i, d - 1) = tail[permutation_[i]];
  }
}

StepReport ProjectiveDynamics::step(const StepInput& input, State& state, double dt,
                                    int minSubsteps, VectorX& pinForce) {
  StepReport report;
  Model& model = *input.model;
  const int d = model.dim();
  const Index n = model.numVertices();
  const std::vector<char>& pinned = *input.pinned;
  const VectorX& mass = model.dofMasses();
  if (input.damping.stiffnessProportional > 0.0) {
    report.ok = false;
    report.error = "projective_dynamics supports mass-proportional damping only "
                   "(damping.stiffness must be 0)";
    return report;
  }
  const int substeps = std::max(minSubsteps, 1);
  report.substeps = substeps;
  const double h = dt / substeps;
  if (!prepare(input, h, &report.error)) {
    report.ok = false;
    return report;
  }
  const double alpha = input.damping.massProportional;
  const double rho = settings_.chebyshevRho;
  const VectorX& target = *input.pinTarget;
  const VectorX& gravity = *input.gravityForce;
  const VectorX& external = *input.externalForce;
  const Index nf = static_cast<Index>(freeVertices_.size());

  for (int s = 0; s < substeps; ++s) {
    xPrev_ = state.x;
    xhat_ = state.x + h * state.v;
    // Pins move to their interpolated targets; free vertices start from the explicit
    // prediction.
    for (Index i = 0; i < n * d; ++i) {
      state.x[i] = pinned[i] ? xPrev_[i] + (target[i] - xPrev_[i]) / (substeps - s)
                             : xhat_[i] + h * h * (gravity[i] + external[i]) / mass[i];
    }
    Index p = 0;
    for (Index i = 0; i < n; ++i) {
      if (freeIndex_[i] < 0) {
        for (int k = 0; k < d; ++k) pinnedPositions_(p, k) = state.x[d * i + k];
        ++p;
      }
    }
    xPrevPrev_ = state.x;
    double omega = 1.0;
    for (int it = 0; it < settings_.iterations; ++it) {
      // Local step: the projections, as the right-hand side sum_i w_i S_i^T p_i(x).
      rhs_.setZero(n * d);
      for (std::size_t t = 0; t < model.numTerms(); ++t) model.term(t).addProjectiveRhs(state.x, &rhs_);
      // Global step on the free vertices: A_ff x_f = b_f - A_fp x_p.
      for (Index k = 0; k < nf; ++k) {
        const Index i = freeVertices_[k];
        for (int c = 0; c < d; ++c) {
          const Index dof = d * i + c;
          rhsFree_(k, c) = rhs_[dof] + gravity[dof] + external[dof] +
                           mass[dof] * (xhat_[dof] / (h * h) + alpha * xPrev_[dof] / h);
        }
      }
      rhsFree_.noalias() -= couplingFreePinned_ * pinnedPositions_;
      solveAllCoordinates();
      if (rho > 0.0) {
        // Chebyshev semi-iteration (Wang 2015, eq. 6): blend with the iterate before last.
        omega = it == 0 ? 1.0 : (it == 1 ? 2.0 / (2.0 - rho * rho) : 4.0 / (4.0 - rho * rho * omega));
      }
      for (Index k = 0; k < nf; ++k) {
        const Index i = freeVertices_[k];
        for (int c = 0; c < d; ++c) {
          const Index dof = d * i + c;
          const double next = omega * (solFree_(k, c) - xPrevPrev_[dof]) + xPrevPrev_[dof];
          xPrevPrev_[dof] = state.x[dof];
          state.x[dof] = next;
        }
      }
    }
    report.iterations += settings_.iterations;
    state.v = (state.x - xPrev_) / h;
    if (!state.x.allFinite() || !state.v.allFinite()) {
      report.ok = false;
      report.error = "projective_dynamics: the state became non-finite";
      return report;
    }
    if (alpha > 0.0) report.dissipated += h * alpha * state.v.dot(mass.cwiseProduct(state.v));
    if (s + 1 == substeps) {
      // The pins supply what balances the incremental potential on their DOFs:
      // f_pin = M (x - xhat)/h^2 + alpha M v - f + (L x - sum_i w_i S_i^T p_i).
      pinForce.setZero();
      for (Index i = 0; i < n; ++i) {
        if (freeIndex_[i] >= 0) continue;
        for (int c = 0; c < d; ++c) {
          const Index dof = d * i + c;
          double lx = 0.0;
          for (Matrix::InnerIterator it(laplacian_, i); it; ++it) lx += it.value() * state.x[d * it.row() + c];
          pinForce[dof] = mass[dof] * ((state.x[dof] - xhat_[dof]) / (h * h) + alpha * state.v[dof]) -
                          gravity[dof] - external[dof] + lx - rhs_[dof];
        }
      }
    }
  }
  report.dtUsed = h;
  return report;
}

}  // namespace fem_cloth
