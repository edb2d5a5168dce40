#include "fem_cloth/core/potential/terms.h"

#include <cmath>
#include <stdexcept>

#include "fem_cloth/core/air.h"
#include "fem_cloth/core/contact/contact_model.h"
#include "fem_cloth/core/integrators/step_common.h"

namespace fem_cloth {

// --- Elastic -----------------------------------------------------------------------------------

EvalResult ElasticTerm::evaluate(const VectorX& x, const TermRequest& request) {
  // The Model adds its Hessian unscaled: the potential assembles it first, into the zeroed
  // pattern, and scales it there.
  if (request.hessian != nullptr && request.hessianScale != 1.0) {
    throw std::invalid_argument("ElasticTerm: the Model assembles unscaled Hessians only");
  }
  EvalRequest r;
  r.energy = request.energy;
  r.gradient = request.gradient;
  r.hessian = request.hessian;
  r.hessianMode = request.hessianMode;
  return model_->evaluate(x, r);
}

TermCapabilities ElasticTerm::capabilities() const {
  TermCapabilities c;
  c.perVertex = model_ != nullptr && model_->hasVertexDerivatives();
  return c;
}

void ElasticTerm::prepareVertexAccess() { model_->prepareVertexAccess(); }

bool ElasticTerm::vertexDerivatives(const VectorX& x, Index vertex, HessianMode mode,
                                    VertexDerivatives& out) const {
  return model_->vertexDerivatives(x, vertex, mode, out);
}

// --- Loads -------------------------------------------------------------------------------------

EvalResult LoadTerm::evaluate(const VectorX& x, const TermRequest& request) {
  EvalResult r;
  if (request.energy) r.energy = -force_.dot(x);
  if (request.gradient != nullptr) *request.gradient -= force_;
  return r;
}

bool LoadTerm::vertexDerivatives(const VectorX& /*x*/, Index vertex, HessianMode /*mode*/,
                                 VertexDerivatives& out) const {
  out = VertexDerivatives{};
  out.force.head(dim_) = force_.segment(dim_ * vertex, dim_);
  return true;
}

// --- Mass damping ------------------------------------------------------------------------------

EvalResult MassDampingTerm::evaluate(const VectorX& x, const TermRequest& request) {
  EvalResult r;
  const VectorX& m = *mass_;
  const VectorX& xc = *frame_.xc;
  if (request.energy) {
    double damping = 0.0;
    for (Eigen::Index i = 0; i < x.size(); ++i) {
      const double d = x[i] - xc[i];
      damping += alpha_ * m[i] * d * d;
    }
    r.energy = 0.5 * frame_.c2 * frame_.gamma * damping;
  }
  if (request.gradient != nullptr) {
    *request.gradient += (frame_.c2 * frame_.gamma * alpha_) * m.cwiseProduct(x - xc);
  }
  // The Hessian, c^2 gamma alpha M, is massProportionalHessian(): the potential adds it.
  return r;
}

bool MassDampingTerm::vertexDerivatives(const VectorX& x, Index vertex, HessianMode /*mode*/,
                                        VertexDerivatives& out) const {
  const int d = frame_.dim;
  const double k = massProportionalHessian() * (*mass_)[d * vertex];
  out = VertexDerivatives{};
  out.force.head(d) = -k * (x.segment(d * vertex, d) - frame_.xc->segment(d * vertex, d));
  out.hessian.topLeftCorner(d, d) = k * Eigen::MatrixXd::Identity(d, d);
  return true;
}

double MassDampingTerm::dissipated(const VectorX& v, double h) const {
  return massDampingDissipation(h, alpha_, v, *mass_);
}

// --- Stiffness damping -------------------------------------------------------------------------

void StiffnessDampingTerm::beginSubstep(const SubstepFrame& frame) {
  frame_ = frame;
  SparseHessian& hessian = model_->hessianPattern();
  hessian.setZero();
  EvalRequest request;
  request.energy = false;
  request.hessian = &hessian;
  model_->evaluate(*frame.x0, request);
  const auto& A = hessian.matrix();
  values_.assign(A.valuePtr(), A.valuePtr() + A.nonZeros());
  for (double& v : values_) v *= beta_;
}

void StiffnessDampingTerm::product(const VectorX& z, VectorX& y) const {
  const auto& pattern = model_->hessianPattern().matrix();
  y.setZero(pattern.rows());
  const int* outer = pattern.outerIndexPtr();
  const int* inner = pattern.innerIndexPtr();
  for (Eigen::Index j = 0; j < pattern.outerSize(); ++j) {
    const double zj = z[j];
    for (int k = outer[j]; k < outer[j + 1]; ++k) y[inner[k]] += values_[k] * zj;
  }
}

EvalResult StiffnessDampingTerm::evaluate(const VectorX& x, const TermRequest& request) {
  EvalResult r;
  const double weight = frame_.c2 * frame_.gamma;
  if (request.energy || request.gradient != nullptr) {
    const VectorX d = x - *frame_.xc;
    product(d, scratch_);
    if (request.energy) r.energy = 0.5 * weight * d.dot(scratch_);
    if (request.gradient != nullptr) *request.gradient += weight * scratch_;
  }
  if (request.hessian != nullptr) {
    double* values = request.hessian->values();
    for (std::size_t k = 0; k < values_.size(); ++k) values[k] += weight * values_[k];
  }
  return r;
}

bool StiffnessDampingTerm::vertexDerivatives(const VectorX& x, Index vertex,
                                             HessianMode /*mode*/, VertexDerivatives& out) const {
  // beta K0 is PSD (projected at the start of the substep): one block for both modes.
  // Row 3v + a of the symmetric beta K0 is its column 3v + a.
  const auto& pattern = model_->hessianPattern().matrix();
  const int* outer = pattern.outerIndexPtr();
  const int* inner = pattern.innerIndexPtr();
  const VectorX& xc = *frame_.xc;
  const double weight = frame_.c2 * frame_.gamma;
  const int d = frame_.dim;
  out = VertexDerivatives{};
  for (int a = 0; a < d; ++a) {
    const Index column = d * vertex + a;
    for (int k = outer[column]; k < outer[column + 1]; ++k) {
      const int i = inner[k];
      out.force[a] -= weight * values_[static_cast<std::size_t>(k)] * (x[i] - xc[i]);
      if (i / d == vertex) out.hessian(i % d, a) = weight * values_[static_cast<std::size_t>(k)];
    }
  }
  return true;
}

double StiffnessDampingTerm::dissipated(const VectorX& v, double h) {
  product(v, scratch_);
  return h * v.dot(scratch_);
}

// --- Air ---------------------------------------------------------------------------------------

void AirTerm::beginSubstep(const SubstepFrame& frame) {
  frame_ = frame;
  air_->lag(*frame.x0);  // normals and areas at the start of the substep
}

EvalResult AirTerm::evaluate(const VectorX& x, const TermRequest& request) {
  // D at v = gamma (x - xc), as c^2 / gamma D (backward Euler: h^2 (h D)), whose x-gradient is
  // -c^2 times the air force and whose x-Hessian is c^2 gamma d^2D/dv^2 (PSD; air.h).
  EvalResult r;
  velocity_ = frame_.gamma * (x - *frame_.xc);
  if (request.energy) r.energy = frame_.c2 / frame_.gamma * air_->dissipation(velocity_);
  if (request.gradient != nullptr) {
    air_->force(velocity_, force_);
    *request.gradient -= frame_.c2 * force_;
  }
  if (request.hessian != nullptr) air_->addHessian(velocity_, frame_.c2 * frame_.gamma, *request.hessian);
  return r;
}

void AirTerm::prepareVertexAccess() { air_->prepareVertexAccess(); }

bool AirTerm::vertexDerivatives(const VectorX& x, Index vertex, HessianMode /*mode*/,
                                VertexDerivatives& out) const {
  if (!air_->vertexDerivatives(x, *frame_.xc, frame_.gamma, vertex, out)) return false;
  out.force *= frame_.c2;
  out.hessian *= frame_.c2 * frame_.gamma;
  return true;
}

const VectorX& AirTerm::force(const VectorX& v) {
  air_->force(v, force_);
  return force_;
}

// --- Contact ---------------------------------------------------------------------------------

namespace {

// One part of the contact as a term: ContactModel scales its gradient and Hessian alike, so a
// scaled Hessian is asked for alone.
EvalResult evaluateContact(ContactModel& contact, const VectorX& x, const TermRequest& request,
                           ContactModel::Part part) {
  double e = 0.0;
  if (request.hessian == nullptr || request.hessianScale == 1.0) {
    e = contact.evaluate(x, request.gradient, request.hessian, request.outside, 1.0, part,
                         request.energyStart);
  } else {
    e = contact.evaluate(x, nullptr, request.hessian, request.outside, request.hessianScale, part,
                         request.energyStart);
    if (request.gradient != nullptr) {
      e = contact.evaluate(x, request.gradient, nullptr, nullptr, 1.0, part, request.energyStart);
    }
  }
  // A zero contact distance, like an element outside its domain, makes the energy +inf.
  EvalResult r;
  r.energy = e;
  r.inDomain = std::isfinite(e);
  return r;
}

}  // namespace

void BarrierTerm::beginSubstep(const SubstepFrame& frame) {
  contact_->beginSubstep(*frame.x0, *frame.xc, frame.gamma, frame.h, *frame.pinned,
                         frame.fractionStart, frame.fractionEnd);
}

EvalResult BarrierTerm::evaluate(const VectorX& x, const TermRequest& request) {
  return evaluateContact(*contact_, x, request, ContactModel::Part::Barriers);
}

double BarrierTerm::prepareStep(const VectorX& x, const VectorX& dx, VectorX* perDof) {
  return contact_->prepareSegment(x, dx, true, perDof);
}

void BarrierTerm::prepareVertexAccess() { contact_->prepareVertexAccess(); }

bool BarrierTerm::vertexDerivatives(const VectorX& x, Index vertex, HessianMode /*mode*/,
                                    VertexDerivatives& out) const {
  return contact_->vertexDerivatives(x, vertex, out, ContactModel::Part::Barriers);
}

EvalResult FrictionTerm::evaluate(const VectorX& x, const TermRequest& request) {
  return evaluateContact(*contact_, x, request, ContactModel::Part::Friction);
}

void FrictionTerm::prepareVertexAccess() { contact_->prepareVertexAccess(); }

bool FrictionTerm::vertexDerivatives(const VectorX& x, Index vertex, HessianMode /*mode*/,
                                     VertexDerivatives& out) const {
  return contact_->vertexDerivatives(x, vertex, out, ContactModel::Part::Friction);
}

}  // namespace fem_cloth
