#include "fem_cloth/core/potential/incremental_potential.h"

#include <algorithm>
#include <cmath>

namespace fem_cloth {

void IncrementalPotential::beginSubstep(ImplicitScheme scheme, const State& state, double h,
                                        int dim, const VectorX& mass,
                                        const std::vector<char>& pinned, double fractionStart,
                                        double fractionEnd) {
  mass_ = &mass;
  bdf2_ = scheme == ImplicitScheme::Bdf2 && state.hasHistoryFor(h);
  frame_ = SubstepFrame{};
  if (bdf2_) {
    xhat_ = (4.0 / 3.0) * state.x - (1.0 / 3.0) * state.xPrevious +
            (8.0 / 9.0) * h * state.v - (2.0 / 9.0) * h * state.vPrevious;
    frame_.c2 = 4.0 / 9.0 * h * h;
    frame_.gamma = 1.5 / h;
    xc_ = (4.0 * state.x - state.xPrevious) / 3.0;
  } else {
    xhat_ = state.x + h * state.v;
    frame_.c2 = h * h;
    frame_.gamma = 1.0 / h;
    xc_ = state.x;
  }
  frame_.x0 = &state.x;
  frame_.xc = &xc_;
  frame_.h = h;
  frame_.pinned = &pinned;
  frame_.fractionStart = fractionStart;
  frame_.fractionEnd = fractionEnd;
  frame_.dim = dim;
  terms_.clear();
  conservative_.clear();
  dissipative_.clear();
  bounded_.clear();
}

void IncrementalPotential::addTerm(PotentialTerm& term) {
  terms_.push_back(&term);
  (term.role() == TermRole::Dissipative ? dissipative_ : conservative_).push_back(&term);
  if (term.capabilities().stepBound) bounded_.push_back(&term);
  term.beginSubstep(frame_);
}

void IncrementalPotential::prepareVertexAccess() {
  for (PotentialTerm* term : terms_) term->prepareVertexAccess();
}

TermsEvaluation IncrementalPotential::evaluateTerms(const VectorX& x, VectorX* termGradient) {
  if (termGradient != nullptr) termGradient->setZero(x.size());
  TermRequest request;
  request.gradient = termGradient;
  TermsEvaluation result;
  // A term that continues the previous one's sum replaces it: each run of such terms is added
  // once, as the single term it was split from.
  double pending = 0.0;
  const PotentialTerm* pendingTerm = nullptr;
  auto flush = [&] {
    if (pendingTerm != nullptr) (pendingTerm->role() == TermRole::Load ? result.load : result.stored) += pending;
  };
  for (PotentialTerm* term : conservative_) {
    const bool continues = term->continuesSum() && pendingTerm != nullptr;
    request.energyStart = continues ? pending : 0.0;
    const EvalResult r = term->evaluate(x, request);
    if (!continues) flush();
    pending = r.energy;
    pendingTerm = term;
    if (!r.inDomain || !std::isfinite(r.energy)) {
      result.inDomain = false;
      result.firstBadElement = r.firstBadElement;
      break;
    }
  }
  flush();
  return result;
}

double IncrementalPotential::value(const VectorX& x, const TermsEvaluation& terms) {
  const double energy = terms.energy();
  if (!std::isfinite(energy)) return kInfiniteEnergy;
  const VectorX& m = *mass_;
  double inertia = 0.0;
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    const double d = x[i] - xhat_[i];
    inertia += m[i] * d * d;
  }
  double phi = 0.5 * inertia + frame_.c2 * energy;
  TermRequest request;
  for (PotentialTerm* term : dissipative_) phi += term->evaluate(x, request).energy;
  return phi;
}

void IncrementalPotential::gradient(const VectorX& x, const VectorX& termGradient, VectorX& out) {
  out = mass_->cwiseProduct(x - xhat_) + frame_.c2 * termGradient;
  TermRequest request;
  request.energy = false;
  request.gradient = &out;
  for (PotentialTerm* term : dissipative_) term->evaluate(x, request);
}

void IncrementalPotential::hessian(const VectorX& x, SparseHessian& hessian,
                                   std::vector<Eigen::Triplet<double>>& outside) {
  hessian.setZero();
  outside.clear();
  TermRequest request;
  request.energy = false;
  request.hessian = &hessian;
  request.outside = &outside;
  // The Model's terms assemble into the zeroed pattern: scaling once costs one multiplication
  // per entry instead of one per element entry.
  auto first = conservative_.begin();
  while (first != conservative_.end() && !(*first)->capabilities().hessian) ++first;
  if (first != conservative_.end()) {
    (*first)->evaluate(x, request);
    double* values = hessian.values();
    const Eigen::Index nnz = hessian.matrix().nonZeros();
    for (Eigen::Index k = 0; k < nnz; ++k) values[k] *= frame_.c2;
  }
  // The inertia and the mass-proportional terms: M (1 + sum k).
  double k = 0.0;
  for (PotentialTerm* term : dissipative_) k += term->massProportionalHessian();
  const VectorX& m = *mass_;
  double* values = hessian.values();
  for (Index i = 0; i < m.size(); ++i) values[hessian.diagonalOffset(i)] += m[i] * (1.0 + k);
  for (PotentialTerm* term : dissipative_) {
    if (term->capabilities().hessian) term->evaluate(x, request);
  }
  request.hessianScale = frame_.c2;
  for (auto it = conservative_.begin(); it != conservative_.end(); ++it) {
    if (it != first && (*it)->capabilities().hessian) (*it)->evaluate(x, request);
  }
}

double IncrementalPotential::prepareStep(const VectorX& x, const VectorX& dx, VectorX* perDof) {
  double t = 1.0;
  for (PotentialTerm* term : bounded_) t = std::min(t, term->prepareStep(x, dx, perDof));
  if (perDof != nullptr) *perDof = perDof->cwiseMax(t);
  return t;
}

double IncrementalPotential::roundoff(double phi, const TermsEvaluation& terms) const {
  return std::abs(phi) + 2.0 * frame_.c2 * (std::abs(terms.stored) + std::abs(terms.load));
}

}  // namespace fem_cloth
