#include "fem_cloth/core/integrators/linear_solver.h"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <numeric>
#include <vector>

#ifdef FEM_CLOTH_HAVE_CHOLMOD
#include <cholmod.h>
#include <dlfcn.h>
#endif
#ifdef _OPENMP
#include <omp.h>
#endif

namespace fem_cloth {

bool cholmodAvailable() {
#ifdef FEM_CLOTH_HAVE_CHOLMOD
  return true;
#else
  return false;
#endif
}

Expected<LinearSolverKind> parseLinearSolverKind(const std::string& name) {
  if (name == "auto") return LinearSolverKind::Auto;
  if (name == "ldlt") return LinearSolverKind::Ldlt;
  if (name == "cholmod" || name == "simplicial") {
    if (!cholmodAvailable()) {
      return Error{"linear solver '" + name +
                   "' is not available: this build has no SuiteSparse CHOLMOD (install "
                   "libsuitesparse-dev and rebuild, or use 'ldlt')"};
    }
    return name == "cholmod" ? LinearSolverKind::Cholmod : LinearSolverKind::Simplicial;
  }
  if (name == "cg") return LinearSolverKind::Cg;
  return Error{"unknown linear solver '" + name + "' (known: auto, simplicial, cholmod, ldlt, cg)"};
}

std::string linearSolverName(LinearSolverKind kind) {
  switch (kind) {
    case LinearSolverKind::Auto: return "auto";
    case LinearSolverKind::Simplicial: return "simplicial";
    case LinearSolverKind::Cholmod: return "cholmod";
    case LinearSolverKind::Ldlt: return "ldlt";
    case LinearSolverKind::Cg: return "cg";
  }
  return "?";
}

LinearSolverKind resolveLinearSolverKind(LinearSolverKind kind, Index numDofs) {
  if (kind != LinearSolverKind::Auto) return kind;
  if (numDofs > kAutoDirectLimit) return LinearSolverKind::Cg;
  if (!cholmodAvailable()) return LinearSolverKind::Ldlt;
  return LinearSolverKind::Auto;  // simplicial or supernodal, by the analysis of each pattern
}

namespace {

using Matrix = LinearSolver::Matrix;

/// Whether A has the pattern recorded in (outer, inner); compared whole, which is cheap next to
/// a factorisation (self-contact can change the pattern between calls).
bool samePattern(const Matrix& A, const std::vector<int>& outer, const std::vector<int>& inner) {
  return A.nonZeros() == static_cast<Eigen::Index>(inner.size()) &&
         A.outerSize() + 1 == static_cast<Eigen::Index>(outer.size()) &&
         std::equal(A.outerIndexPtr(), A.outerIndexPtr() + A.outerSize() + 1, outer.begin()) &&
         std::equal(A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros(), inner.begin());
}

void recordPattern(const Matrix& A, std::vector<int>& outer, std::vector<int>& inner) {
  outer.assign(A.outerIndexPtr(), A.outerIndexPtr() + A.outerSize() + 1);
  inner.assign(A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros());
}

// Eigen's LDL^T (builds without SuiteSparse): analysePattern once, factorize every call.
class EigenLdltSolver final : public LinearSolver {
 public:
  std::string name() const override { return "ldlt"; }
  bool compute(const Matrix& A) override {
    if (analyses_ == 0 || !samePattern(A, analysedOuter_, analysedInner_)) {
      solver_.analyzePattern(A);
      recordPattern(A, analysedOuter_, analysedInner_);
      ++analyses_;
    }
    solver_.factorize(A);
    return solver_.info() == Eigen::Success;
  }
  bool solve(const VectorX& b, VectorX& x) override {
    x = solver_.solve(b);
    return solver_.info() == Eigen::Success && x.allFinite();
  }

 private:
  Eigen::SimplicialLDLT<Matrix, Eigen::Lower, Eigen::AMDOrdering<int>> solver_;
  std::vector<int> analysedOuter_, analysedInner_;
};

#ifdef FEM_CLOTH_HAVE_CHOLMOD

// Eigen's simplicial LL^T of a matrix already in its elimination order (natural ordering, upper
// triangle), factorised without the empty work matrix SimplicialLLT::factorize() builds (and
// allocates) at every call: the same arithmetic, no allocation.
class PreorderedLlt : public Eigen::SimplicialLLT<LinearSolver::Matrix, Eigen::Upper, Eigen::NaturalOrdering<int>> {
 public:
  void factorizePreordered(const LinearSolver::Matrix& upper) { this->template factorize_preordered<false>(upper); }
};

// CHOLMOD's supernodal factorisation opens OpenMP parallel regions of its own, with a thread
// count compiled into Debian's library (4) that OMP_NUM_THREADS does not change, at every large
// supernode: thousands of thread wake-ups per factorisation, each costing more than the copy it
// shares. With them, 65x65 backward Euler spent a third of its time in futex calls (1.02 s wall
// against 0.56 s without, 5 steps, measured 2026-12, docs/performance.md). While this guard
// lives, every parallel region on this thread runs on it alone (max-active-levels 0).
class SerialOpenMp {
 public:
#ifdef _OPENMP
  SerialOpenMp() : saved_(omp_get_max_active_levels()) { omp_set_max_active_levels(0); }
  ~SerialOpenMp() { omp_set_max_active_levels(saved_); }

 private:
  int saved_;
#endif
};

// OpenBLAS (the BLAS scripts/install-deps installs) runs its own threads, sized to the machine,
// which would compete with the element loops for the cores and make results depend on the
// thread count. The factorisation calls it with one thread: its results are then the same from
// run to run and for any OMP_NUM_THREADS (still only on one machine: OpenBLAS picks its kernels
// by CPU). Looked up at run time, because the BLAS behind libblas.so.3 is the system's choice
// (Debian's alternatives); with any other BLAS this does nothing.
void useOneBlasThread() {
  static const bool done = [] {
    using SetThreads = void (*)(int);
    if (auto set = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))) set(1);
    return true;
  }();
  (void)done;
}

// LL^T of the matrix permuted once by the fill-reducing ordering CHOLMOD picks for its pattern:
// supernodal by CHOLMOD (dense updates in the BLAS), or simplicial by Eigen's up-looking
// factorisation (no BLAS, so the same bits on every machine that runs this build; on the
// 13x13 pinch-lift it also beat CHOLMOD's own simplicial one, 1.43 s against 1.55 s, 2026-12).
// The permuted upper triangle is a matrix of this class, refilled through a map at every call:
// both factorise it in its natural order, without the transposes, permutations and copies they
// make of an unpermuted or lower-stored matrix.
class CholmodSolver final : public LinearSolver {
 public:
  /// Supernodal, simplicial, or (automatic) whichever the flop count of each analysed pattern's
  /// factor calls for (kAutoSimplicialFlops).
  CholmodSolver(bool supernodal, bool automatic) : supernodal_(supernodal), automatic_(automatic) {
    cholmod_start(&common_);
    common_.supernodal = CHOLMOD_SUPERNODAL;
    common_.print = 0;     // a matrix that is not positive definite fails compute(): no message
    useOneBlasThread();
  }
  ~CholmodSolver() override {
    cholmod_free_factor(&factor_, &common_);
    cholmod_free_dense(&x_, &common_);
    cholmod_free_dense(&y_, &common_);
    cholmod_free_dense(&e_, &common_);
    cholmod_finish(&common_);
  }
  CholmodSolver(const CholmodSolver&) = delete;
  CholmodSolver& operator=(const CholmodSolver&) = delete;

  std::string name() const override { return supernodal_ ? "cholmod" : "simplicial"; }

  bool compute(const Matrix& A) override {
    if (analyses_ == 0 || !samePattern(A, analysedOuter_, analysedInner_)) {
      if (!analyse(A)) return false;
      recordPattern(A, analysedOuter_, analysedInner_);
      ++analyses_;
    }
    const double* values = A.valuePtr();
    double* permuted = permuted_.valuePtr();
    for (std::size_t k = 0; k < source_.size(); ++k) permuted[k] = values[source_[k]];
    if (!supernodal_) {
      llt_.factorizePreordered(permuted_);
      return llt_.info() == Eigen::Success;
    }
    cholmod_sparse P = view(permuted_);
    SerialOpenMp serial;
    cholmod_factorize(&P, factor_, &common_);
    return common_.status == CHOLMOD_OK && factor_->minor == factor_->n;
  }

  bool solve(const VectorX& b, VectorX& x) override {
    const Index n = b.size();
    work_.resize(n);
    for (Index k = 0; k < n; ++k) work_[k] = b[perm_[static_cast<std::size_t>(k)]];
    if (supernodal_) {
      cholmod_dense B = denseView(work_);
      SerialOpenMp serial;
      if (cholmod_solve2(CHOLMOD_A, factor_, &B, nullptr, &x_, nullptr, &y_, &e_, &common_) != 1) return false;
      std::copy_n(static_cast<const double*>(x_->x), n, work_.data());
    } else {
      llt_.matrixL().solveInPlace(work_);
      llt_.matrixU().solveInPlace(work_);
    }
    x.resize(n);
    for (Index k = 0; k < n; ++k) x[perm_[static_cast<std::size_t>(k)]] = work_[k];
    return x.allFinite();
  }

 private:
  // A cholmod_sparse over a compressed matrix of ours: symmetric, upper triangle (stype 1),
  // sorted, packed.
  static cholmod_sparse view(Matrix& M) {
    cholmod_sparse S{};
    S.nrow = S.ncol = static_cast<std::size_t>(M.cols());
    S.nzmax = static_cast<std::size_t>(M.nonZeros());
    S.p = M.outerIndexPtr();
    S.i = M.innerIndexPtr();
    S.x = M.valuePtr();
    S.stype = 1;
    S.itype = CHOLMOD_INT;
    S.xtype = CHOLMOD_REAL;
    S.dtype = CHOLMOD_DOUBLE;
    S.sorted = 1;
    S.packed = 1;
    return S;
  }
  static cholmod_dense denseView(VectorX& v) {
    cholmod_dense B{};
    B.nrow = B.nzmax = B.d = static_cast<std::size_t>(v.size());
    B.ncol = 1;
    B.x = v.data();
    B.xtype = CHOLMOD_REAL;
    B.dtype = CHOLMOD_DOUBLE;
    return B;
  }

  // The ordering (CHOLMOD's choice: AMD, or METIS when it is better), the permuted upper
  // pattern with its map, and the symbolic factor of the permuted matrix in natural order.
  bool analyse(const Matrix& A) {
    cholmod_free_factor(&factor_, &common_);
    const int n = static_cast<int>(A.rows());
    Matrix pattern = A;  // CHOLMOD reads only the upper triangle's pattern here
    cholmod_sparse S = view(pattern);
    common_.nmethods = 0;  // CHOLMOD's default: AMD, and METIS if it is better
    common_.postorder = 1;
    cholmod_factor* ordering = cholmod_analyze(&S, &common_);
    if (ordering == nullptr) return false;
    perm_.assign(static_cast<const int*>(ordering->Perm), static_cast<const int*>(ordering->Perm) + n);
    if (automatic_) supernodal_ = common_.fl > kAutoSimplicialFlops;
    cholmod_free_factor(&ordering, &common_);
    permute(A);
    if (!supernodal_) {
      llt_.analyzePattern(permuted_);
      return llt_.info() == Eigen::Success;
    }
    common_.nmethods = 1;
    common_.method[0].ordering = CHOLMOD_NATURAL;
    common_.postorder = 0;  // perm_ is already postordered
    cholmod_sparse P = view(permuted_);
    factor_ = cholmod_analyze(&P, &common_);
    return factor_ != nullptr;
  }

  // The upper triangle of A(perm, perm): its pattern, and for each entry the slot of A it comes from.
  void permute(const Matrix& A) {
    const int n = static_cast<int>(A.rows());
    std::vector<int> position(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k) position[static_cast<std::size_t>(perm_[static_cast<std::size_t>(k)])] = k;
    std::vector<std::vector<std::pair<int, int>>> columns(static_cast<std::size_t>(n));
    for (int j = 0; j < n; ++j) {
      for (int k = A.outerIndexPtr()[j]; k < A.outerIndexPtr()[j + 1]; ++k) {
        const int pi = position[static_cast<std::size_t>(A.innerIndexPtr()[k])];
        const int pj = position[static_cast<std::size_t>(j)];
        if (pi <= pj) columns[static_cast<std::size_t>(pj)].emplace_back(pi, k);
      }
    }
    std::vector<Eigen::Triplet<double, int>> entries;
    source_.clear();
    for (int j = 0; j < n; ++j) {
      auto& column = columns[static_cast<std::size_t>(j)];
      std::sort(column.begin(), column.end());
      for (const auto& [row, slot] : column) {
        entries.emplace_back(row, j, 0.0);
        source_.push_back(slot);
      }
    }
    permuted_.resize(n, n);
    permuted_.setFromTriplets(entries.begin(), entries.end());  // column by column, rows sorted:
    permuted_.makeCompressed();                                   // slot k is source_[k]'s entry
  }

  bool supernodal_;
  bool automatic_;
  cholmod_common common_{};
  cholmod_factor* factor_ = nullptr;
  cholmod_dense *x_ = nullptr, *y_ = nullptr, *e_ = nullptr;  // cholmod_solve2's, reused
  std::vector<int> perm_;  // permuted row k is row perm_[k] of A
  Matrix permuted_;           // upper triangle of A(perm, perm), values refilled per call
  std::vector<int> source_;   // permuted_'s k-th entry is A's entry source_[k]
  PreorderedLlt llt_;  // simplicial
  std::vector<int> analysedOuter_, analysedInner_;
  VectorX work_;
};

#endif

class CgSolver final : public LinearSolver {
 public:
  explicit CgSolver(const LinearSolverSettings& settings) {
    solver_.setTolerance(settings.cgTolerance);
    solver_.setMaxIterations(settings.cgMaxIterations);
  }
  std::string name() const override { return "cg"; }
  bool compute(const Matrix& A) override {
    if (analyses_ == 0) ++analyses_;
    solver_.compute(A);
    return solver_.info() == Eigen::Success;
  }
  bool solve(const VectorX& b, VectorX& x) override {
    x = solver_.solveWithGuess(b, x);
    lastIterations_ = static_cast<int>(solver_.iterations());
    return x.allFinite() && (solver_.info() == Eigen::Success || solver_.error() < 1e-4);
  }

 private:
  Eigen::ConjugateGradient<Matrix, Eigen::Lower | Eigen::Upper,
                           Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::AMDOrdering<int>>>
      solver_;
};

}  // namespace

std::unique_ptr<LinearSolver> makeLinearSolver(const LinearSolverSettings& settings,
                                               Index numDofs) {
  switch (resolveLinearSolverKind(settings.kind, numDofs)) {
    case LinearSolverKind::Cg: return std::make_unique<CgSolver>(settings);
#ifdef FEM_CLOTH_HAVE_CHOLMOD
    case LinearSolverKind::Auto: return std::make_unique<CholmodSolver>(false, true);
    case LinearSolverKind::Cholmod: return std::make_unique<CholmodSolver>(true, false);
    case LinearSolverKind::Simplicial: return std::make_unique<CholmodSolver>(false, false);
#endif
    default: return std::make_unique<EigenLdltSolver>();
  }
}

}  // namespace fem_cloth
