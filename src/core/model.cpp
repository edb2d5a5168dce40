#include "fem_cloth/core/model.h"

namespace fem_cloth {

Model::Model(std::shared_ptr<const Mesh> mesh, std::shared_ptr<const RestState> rest,
             VectorX vertexMasses)
    : mesh_(std::move(mesh)), rest_(std::move(rest)), vertexMasses_(std::move(vertexMasses)) {
  const int d = mesh_->dim;
  dofMasses_.resize(vertexMasses_.size() * d);
  for (Eigen::Index i = 0; i < vertexMasses_.size(); ++i) {
    dofMasses_.segment(d * i, d).setConstant(vertexMasses_[i]);
  }
}

void Model::addTerm(std::unique_ptr<EnergyTerm> term, TermKind kind) {
  if (hessian_ != nullptr) {
    // A new term may couple new vertices: rebuild the pattern on next use.
    hessian_.reset();
  }
  hasValidityRanges_ = hasValidityRanges_ || term->hasValidityRange();
  terms_.push_back({std::move(term), kind});
}

Model::TermValidity Model::validity(const VectorX& x) const {
  TermValidity worst;
  if (!hasValidityRanges_) return worst;
  for (std::size_t t = 0; t < terms_.size(); ++t) {
    if (!terms_[t].term->hasValidityRange()) continue;
    const Validity v = terms_[t].term->validity(x);
    // The term furthest outside (or closest to) its limit, relative to the limit.
    if (worst.term < 0 || !(v.measure / v.limit <= worst.validity.measure / worst.validity.limit)) {
      worst.validity = v;
      worst.term = static_cast<int>(t);
    }
  }
  return worst;
}

EvalResult Model::evaluate(const VectorX& x, const EvalRequest& request) {
  EvalResult total;
  for (Entry& entry : terms_) {
    const EvalResult r = entry.term->evaluate(x, request);
    total.energy += r.energy;
    if (!r.inDomain && total.inDomain) {
      total.inDomain = false;
      total.firstBadElement = r.firstBadElement;
    }
  }
  if (!total.inDomain) total.energy = kInfiniteEnergy;
  return total;
}

bool Model::hasVertexDerivatives() const {
  for (const Entry& entry : terms_) {
    if (!entry.term->hasVertexDerivatives()) return false;
  }
  return true;
}

void Model::prepareVertexAccess() {
  for (Entry& entry : terms_) entry.term->prepareVertexAccess();
}

bool Model::vertexDerivatives(const VectorX& x, Index vertex, HessianMode mode,
                              VertexDerivatives& out) const {
  VertexDerivatives sum, term;
  for (const Entry& entry : terms_) {
    if (!entry.term->vertexDerivatives(x, vertex, mode, term)) return false;
    sum.force += term.force;
    sum.hessian += term.hessian;
  }
  out = sum;
  return true;
}

Model::Energies Model::energies(const VectorX& x) {
  Energies e;
  EvalRequest request;
  for (Entry& entry : terms_) {
    const EvalResult r = entry.term->evaluate(x, request);
    const double value = r.inDomain ? r.energy : kInfiniteEnergy;
    switch (entry.kind) {
      case TermKind::Membrane: e.membrane += value; break;
      case TermKind::Bending: e.bending += value; break;
      case TermKind::Other: e.other += value; break;
    }
  }
  return e;
}

SparseHessian& Model::hessianPattern() {
  if (hessian_ == nullptr) {
    std::vector<std::vector<Index>> stencils;
    for (const Entry& entry : terms_) entry.term->appendStencils(&stencils);
    hessian_ = std::make_unique<SparseHessian>(numVertices(), dim(), stencils);
    for (Entry& entry : terms_) entry.term->bindHessian(*hessian_);
  }
  return *hessian_;
}

}  // namespace fem_cloth
