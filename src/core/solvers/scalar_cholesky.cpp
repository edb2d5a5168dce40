#include "fem_cloth/core/solvers/scalar_cholesky.h"

#include "fem_cloth/core/energy_term.h"

namespace fem_cloth {

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

bool ScalarCholesky::compute(const Matrix& A, int d) {
  llt_.compute(A);
  if (llt_.info() != Eigen::Success) return false;
  // Keep the factor L (column-major, diagonal first in each column) and the fill-reducing
  // permutation (P A P^T = L L^T).
  const Matrix& L = llt_.matrixL().nestedExpression();
  const Index n = A.rows();
  outer_.assign(L.outerIndexPtr(), L.outerIndexPtr() + L.outerSize() + 1);
  inner_.assign(L.innerIndexPtr(), L.innerIndexPtr() + L.nonZeros());
  values_.assign(L.valuePtr(), L.valuePtr() + L.nonZeros());
  permutation_.assign(llt_.permutationP().indices().data(), llt_.permutationP().indices().data() + n);
  work_.resize(n, d - 1);
  tail_.resize(n);
  return true;
}

void ScalarCholesky::solve(const Block& B, Block& X) {
  const Index nf = size();
  const int d = static_cast<int>(B.cols());
  const int* outer = outer_.data();
  const int* inner = inner_.data();
  const double* value = values_.data();
  // Two independent solves, on two threads for large systems: the first d - 1 coordinates
  // interleaved, the last alone.
  double* head = work_.data();   // nf x (d - 1), row-major
  double* tail = tail_.data();  // nf
  for (Index i = 0; i < nf; ++i) {
    for (int c = 0; c + 1 < d; ++c) head[(d - 1) * permutation_[i] + c] = B(i, c);
    tail[permutation_[i]] = B(i, d - 1);
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
  X.resize(nf, d);
  for (Index i = 0; i < nf; ++i) {
    for (int c = 0; c + 1 < d; ++c) X(i, c) = head[(d - 1) * permutation_[i] + c];
    X(i, d - 1) = tail[permutation_[i]];
  }
}

}  // namespace fem_cloth
