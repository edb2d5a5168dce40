#include "fem_cloth/core/solvers/initial_hessian.h"

#include "fem_cloth/core/solvers/projected_hessian.h"

namespace fem_cloth {

void InitialHessian::invalidate() {
  haveLaplacian_ = false;
  factorisedFor_.clear();
}

void InitialHessian::buildLaplacian(Model& model) {
  const int d = model.dim();
  const Index n = model.numVertices();
  const Matrix& K = projectedHessian(model, model.mesh().restPositions).matrix();
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(static_cast<std::size_t>(K.nonZeros() / d));
  for (Eigen::Index j = 0; j < K.outerSize(); ++j) {
    for (Matrix::InnerIterator it(K, j); it; ++it) {
      if (it.row() % d != j % d) continue;
      triplets.emplace_back(static_cast<Index>(it.row() / d), static_cast<Index>(j / d),
                            it.value() / kLaplacianTraceDivisor);
    }
  }
  laplacian_.resize(n, n);
  laplacian_.setFromTriplets(triplets.begin(), triplets.end());
  dim_ = d;
  haveLaplacian_ = true;
  factorisedFor_.clear();
}

bool InitialHessian::prepare(Model& model, const std::vector<char>& pinned, double a, double b,
                             const VectorX& x, std::string* error) {
  if (!haveLaplacian_) buildLaplacian(model);
  const int d = dim_;
  const Index n = model.numVertices();
  pinnedVertices_.resize(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) pinnedVertices_[i] = pinned[d * i];
  const bool rebuild = !(pinnedVertices_ == factorisedFor_ && a == a_ && b == b_);
  if (rebuild) {
    freeIndex_.assign(static_cast<std::size_t>(n), -1);
    freeVertices_.clear();
    for (Index i = 0; i < n; ++i) {
      if (pinnedVertices_[i]) continue;
      freeIndex_[i] = static_cast<Index>(freeVertices_.size());
      freeVertices_.push_back(i);
    }
    const Index nf = static_cast<Index>(freeVertices_.size());
    std::vector<Eigen::Triplet<double>> triplets;
    for (Eigen::Index j = 0; j < laplacian_.outerSize(); ++j) {
      if (freeIndex_[j] < 0) continue;
      for (Matrix::InnerIterator it(laplacian_, j); it; ++it) {
        if (freeIndex_[it.row()] >= 0) triplets.emplace_back(freeIndex_[it.row()], freeIndex_[j], b * it.value());
      }
    }
    const VectorX& mass = model.vertexMasses();
    for (Index k = 0; k < nf; ++k) triplets.emplace_back(k, k, a * mass[freeVertices_[k]]);
    system_.resize(nf, nf);
    system_.setFromTriplets(triplets.begin(), triplets.end());
    factorisedFor_.clear();
  }
  takeContact(x);
  const bool sameDiagonal = diagonal_.size() == factorisedDiagonal_.size() && diagonal_ == factorisedDiagonal_;
  if (!rebuild && (!options_.traceInFactor || sameDiagonal)) return true;
  if (!factorise(error)) return false;
  factorisedFor_ = pinnedVertices_;
  a_ = a;
  b_ = b;
  return true;
}

bool InitialHessian::factorise(std::string* error) {
  const Index nf = static_cast<Index>(freeVertices_.size());
  factorisedFor_.clear();
  rhs_.resize(nf, dim_);
  factorisedDiagonal_ = diagonal_;
  if (nf == 0) return true;
  bool ok = false;
  if (options_.traceInFactor && diagonal_.size() == nf && diagonal_.any()) {
    Matrix shifted = system_;
    for (Index k = 0; k < nf; ++k) shifted.coeffRef(k, k) += diagonal_[k];
    ok = factor_.compute(shifted, dim_);
  } else {
    ok = factor_.compute(system_, dim_);
  }
  if (!ok) {
    *error = "the initial Hessian of the quasi-Newton solver (M + c^2 L) could not be factorised";
    return false;
  }
  ++factorisations_;
  return true;
}

void InitialHessian::setContact(ContactSource source, const ContactOptions& options) {
  source_ = std::move(source);
  options_ = options;
  if (!source_) contact_.clear();
}

void InitialHessian::takeContact(const VectorX& x) {
  contact_.clear();
  if (source_) source_(x, contact_);
  const Index nf = static_cast<Index>(freeVertices_.size());
  diagonal_.setZero(options_.traceInFactor ? nf : 0);
  if (!options_.traceInFactor) return;
  for (const ContactBlock& c : contact_) diagonal_[freeIndex_[c.vertex]] += c.block.trace() / options_.traceDivisor;
}

bool InitialHessian::refreshContact(const VectorX& x) {
  if (!source_ || (options_.traceInFactor && !options_.followIterate)) return true;
  takeContact(x);
  if (!options_.traceInFactor || diagonal_ == factorisedDiagonal_) return true;
  std::string error;
  const std::vector<char> factorisedFor = factorisedFor_;
  if (!factorise(&error)) return false;
  factorisedFor_ = factorisedFor;
  return true;
}

void InitialHessian::applySystem(const ScalarCholesky::Block& Z, ScalarCholesky::Block& Y) const {
  Y.noalias() = system_ * Z;
  const int d = dim_;
  for (const ContactBlock& c : contact_) {
    const Index k = freeIndex_[c.vertex];
    for (int i = 0; i < d; ++i) {
      for (int j = 0; j < d; ++j) Y(k, i) += c.block(i, j) * Z(k, j);
    }
  }
}

void InitialHessian::conjugateGradients() {
  // Preconditioned CG from zero on A z = rhs, A = B0 x I3 + D, preconditioner the factor.
  solution_.setZero(rhs_.rows(), rhs_.cols());
  r_ = rhs_;
  factor_.solve(r_, s_);
  p_ = s_;
  double rs = r_.cwiseProduct(s_).sum();
  const double stop = options_.pcgTolerance * options_.pcgTolerance * rs;
  for (int k = 0; k < options_.pcgIterations && rs > 0.0; ++k) {
    applySystem(p_, ap_);
    const double pap = p_.cwiseProduct(ap_).sum();
    if (!(pap > 0.0)) break;
    const double alpha = rs / pap;
    solution_ += alpha * p_;
    if (k + 1 == options_.pcgIterations) break;
    r_ -= alpha * ap_;
    factor_.solve(r_, s_);
    const double rsNew = r_.cwiseProduct(s_).sum();
    if (rsNew <= stop) break;
    p_ = s_ + (rsNew / rs) * p_;
    rs = rsNew;
  }
}

void InitialHessian::applyInverse(const VectorX& q, VectorX& z) {
  const int d = dim_;
  const Index nf = static_cast<Index>(freeVertices_.size());
  z.setZero(q.size());
  if (nf == 0) return;
  for (Index j = 0; j < nf; ++j) {
    for (int c = 0; c < d; ++c) rhs_(j, c) = q[d * freeVertices_[j] + c];
  }
  if (contact_.empty() || options_.pcgIterations == 0) {
    factor_.solve(rhs_, solution_);
  } else {
    conjugateGradients();
  }
  for (Index j = 0; j < nf; ++j) {
    for (int c = 0; c < d; ++c) z[d * freeVertices_[j] + c] = solution_(j, c);
  }
}

}  // namespace fem_cloth
