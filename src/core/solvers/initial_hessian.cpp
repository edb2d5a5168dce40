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
                             std::string* error) {
  if (!haveLaplacian_) buildLaplacian(model);
  const int d = dim_;
  const Index n = model.numVertices();
  pinnedVertices_.resize(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) pinnedVertices_[i] = pinned[d * i];
  if (pinnedVertices_ == factorisedFor_ && a == a_ && b == b_) return true;
  std::vector<Index> freeIndex(n, -1);
  freeVertices_.clear();
  for (Index i = 0; i < n; ++i) {
    if (pinnedVertices_[i]) continue;
    freeIndex[i] = static_cast<Index>(freeVertices_.size());
    freeVertices_.push_back(i);
  }
  const Index nf = static_cast<Index>(freeVertices_.size());
  std::vector<Eigen::Triplet<double>> triplets;
  for (Eigen::Index j = 0; j < laplacian_.outerSize(); ++j) {
    if (freeIndex[j] < 0) continue;
    for (Matrix::InnerIterator it(laplacian_, j); it; ++it) {
      if (freeIndex[it.row()] >= 0) triplets.emplace_back(freeIndex[it.row()], freeIndex[j], b * it.value());
    }
  }
  const VectorX& mass = model.vertexMasses();
  for (Index k = 0; k < nf; ++k) triplets.emplace_back(k, k, a * mass[freeVertices_[k]]);
  system_.resize(nf, nf);
  system_.setFromTriplets(triplets.begin(), triplets.end());
  factorisedFor_.clear();
  if (nf > 0 && !factor_.compute(system_, d)) {
    *error = "the initial Hessian of the quasi-Newton solver (M + c^2 L) could not be factorised";
    return false;
  }
  ++factorisations_;
  factorisedFor_ = pinnedVertices_;
  a_ = a;
  b_ = b;
  rhs_.resize(nf, d);
  return true;
}

void InitialHessian::applyInverse(const VectorX& q, VectorX& z) {
  const int d = dim_;
  const Index nf = static_cast<Index>(freeVertices_.size());
  z.setZero(q.size());
  if (nf == 0) return;
  for (Index j = 0; j < nf; ++j) {
    for (int c = 0; c < d; ++c) rhs_(j, c) = q[d * freeVertices_[j] + c];
  }
  factor_.solve(rhs_, solution_);
  for (Index j = 0; j < nf; ++j) {
    for (int c = 0; c < d; ++c) z[d * freeVertices_[j] + c] = solution_(j, c);
  }
}

}  // namespace fem_cloth
