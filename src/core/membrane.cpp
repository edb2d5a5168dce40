#include "fem_cloth/core/membrane.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>

#include "fem_cloth/core/energy_forms.h"

namespace fem_cloth {

namespace {

template <int D, class Model>
class MembraneTerm final : public EnergyTerm, public ConstraintForm, public ProjectiveForm {
 public:
  MembraneTerm(std::shared_ptr<const Mesh> mesh, std::shared_ptr<const RestState> rest,
               const Model& model)
      : mesh_(std::move(mesh)), rest_(std::move(rest)), model_(model) {
    const std::size_t m = mesh_->triangles.size();
    energy_.resize(m);
    inDomain_.resize(m);
    gradient_.resize(m);
    frames_.resize(m);
    for (std::size_t t = 0; t < m; ++t) frames_[t] = rest_->frame<D>(static_cast<Index>(t));
  }

  std::string name() const override { return std::string("membrane/") + Model::kName; }

  void appendStencils(std::vector<std::vector<Index>>* stencils) const override {
    for (const Triangle& t : mesh_->triangles) stencils->push_back({t[0], t[1], t[2]});
  }

  void bindHessian(const SparseHessian& hessian) override {
    const std::size_t m = mesh_->triangles.size();
    offsets_.resize(m * 9 * D);
    std::vector<int> local;
    for (std::size_t t = 0; t < m; ++t) {
      const Triangle& tri = mesh_->triangles[t];
      hessian.stencilOffsets({tri[0], tri[1], tri[2]}, local);
      std::copy(local.begin(), local.end(), offsets_.begin() + static_cast<long>(t * 9 * D));
    }
    hessian_.resize(m);
  }

  // Per-vertex access: vertex a of triangle t gets A P g_a and the block (a, a) of the element
  // Hessian (membrane.h's kernels restricted to one vertex).
  bool hasVertexDerivatives() const override { return true; }
  void prepareVertexAccess() override {
    if (!incidence_.isBuilt()) incidence_.assign(mesh_->numVertices(), mesh_->triangles);
  }
  bool vertexDerivatives(const VectorX& x, Index vertex, HessianMode mode,
                         VertexDerivatives& out) const override {
    if (!incidence_.isBuilt()) return false;  // not prepared
    out = VertexDerivatives{};
    for (const VertexIncidence::Use& use : incidence_.uses(vertex)) {
      const Index t = use.element;
      const DefGrad<D> F = deformationGradient<D>(*mesh_, *rest_, x, t);
      if (!model_.template inDomain<D>(F)) return false;
      const DefGrad<D>& T = frames_[t];
      const double area = rest_->restArea[t];
      const Eigen::Vector2d g = rest_->shapeGradients[t].row(use.slot).transpose();
      out.force.template head<D>() -= area * (model_.template pk1<D>(F, T) * g);
      const StressHessian<D> H = mode == HessianMode::Projected
                                     ? model_.template projectedHessian<D>(F, T)
                                     : model_.template hessian<D>(F, T);
      Eigen::Matrix<double, D, D> block = Eigen::Matrix<double, D, D>::Zero();
      for (int c = 0; c < 2; ++c) {
        for (int e = 0; e < 2; ++e) block += (g[c] * g[e]) * H.template block<D, D>(D * c, D * e);
      }
      out.hessian.template topLeftCorner<D, D>() += area * block;
    }
    return true;
  }

  bool hasValidityRange() const override { return Model::kHasValidityRange; }
  Validity validity(const VectorX& x) const override {
    Validity worst;
    if constexpr (Model::kHasValidityRange) {
      worst.limit = Model::kValidityLimit;
      worst.what = Model::kValidityMeasure;
      worst.advice = Model::kValidityAdvice;
      for (Index t = 0; t < mesh_->numTriangles(); ++t) {
        const double m =
            model_.template validityMeasure<D>(deformationGradient<D>(*mesh_, *rest_, x, t), frames_[t]);
        if (worst.element < 0 || m > worst.measure || !(m == m)) {
          worst.measure = m;
          worst.element = t;
          if (!(m == m)) break;
        }
      }
    } else {
      (void)x;
    }
    return worst;
  }

  // Constraint form (energy_forms.h), one element per triangle, when the material has one
  // (kHasConstraintForm); else none, and XPBD refuses the material.
  const ConstraintForm* constraintForm() const override {
    if constexpr (kHasConstraintForm<Model>) return this;
    return nullptr;
  }
  Index numElements() const override { return mesh_->numTriangles(); }
  int verticesPerElement() const override { return 3; }
  int constraintsPerElement() const override {
    if constexpr (kHasConstraintForm<Model>) return Model::kNumConstraints;
    return 0;
  }
  const Index* elementVertices(Index element) const override {
    return mesh_->triangles[element].data();
  }
  bool elementConstraints(Index t, const VectorX& x, double* C, double* jacobian) const override {
    if constexpr (kHasConstraintForm<Model>) {
      return constraintsOf(t, x, C, jacobian);
    }
    return false;
  }
  void elementConstraintStiffness(Index t, double* K) const override {
    if constexpr (kHasConstraintForm<Model>) {
      const ConstraintStiffness Km = rest_->restArea[t] * model_.constraintStiffness();
      for (int i = 0; i < Km.rows(); ++i) {
        for (int j = 0; j < Km.cols(); ++j) K[i * Km.cols() + j] = Km(i, j);
      }
    }
  }
  // Only instantiated for a material with a constraint form.
  bool constraintsOf(Index t, const VectorX& x, double* C, double* jacobian) const {
    const DefGrad<D> F = deformationGradient<D>(*mesh_, *rest_, x, t);
    if (!model_.template inDomain<D>(F)) return false;
    ConstraintValues values;
    ConstraintJacobian<D> dCdF;
    if (!model_.template constraints<D>(F, frames_[t], values, dCdF)) return false;
    // dC_k/dx_(a,r) = sum_c dC_k/dF_(r,c) g_a[c].
    const Eigen::Matrix<double, 3, 2>& G = rest_->shapeGradients[t];
    const int k = static_cast<int>(values.size());
    for (int row = 0; row < k; ++row) {
      C[row] = values[row];
      for (int a = 0; a < 3; ++a) {
        for (int r = 0; r < D; ++r) {
          jacobian[row * 3 * D + D * a + r] = dCdF(row, r) * G(a, 0) + dCdF(row, r + D) * G(a, 1);
        }
      }
    }
    return true;
  }

  // Projective form of ARAP: A mu |F - R|^2 = (2 mu A)/2 |S x - R|^2 per coordinate row of F,
  // with S the 2 x 3 matrix of shape gradients and R the closest rotation (polar).
  ProjectiveForm* projectiveForm() override {
    if constexpr (std::is_same_v<Model, Arap> && D == 3) return this;
    return nullptr;
  }
  void appendProjectiveMatrix(std::vector<Eigen::Triplet<double>>* triplets) const override {
    for (Index t = 0; t < mesh_->numTriangles(); ++t) {
      const double w = 2.0 * model_.mu() * rest_->restArea[t];
      const Eigen::Matrix<double, 3, 2>& G = rest_->shapeGradients[t];
      const Eigen::Matrix3d block = w * G * G.transpose();
      const Triangle& tri = mesh_->triangles[t];
      for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) triplets->emplace_back(tri[a], tri[b], block(a, b));
      }
    }
  }
  void addProjectiveRhs(const VectorX& x, VectorX* rhs) override {
    const Index m = mesh_->numTriangles();
    if constexpr (D == 3) {
#pragma omp parallel for schedule(static) if (m >= kParallelElementThreshold)
      for (Index t = 0; t < m; ++t) {
        const DefGrad<3> F = deformationGradient<3>(*mesh_, *rest_, x, t);
        const DefGrad<3> R = polarRotation3x2(F);  // the closest rotation (svd.h)
        const double w = 2.0 * model_.mu() * rest_->restArea[t];
        for (int a = 0; a < 3; ++a) {
          gradient_[t].template segment<3>(3 * a) = w * (R * rest_->shapeGradients[t].row(a).transpose());
        }
      }
      // Fixed-order scatter: the same sum for any number of threads.
      for (Index t = 0; t < m; ++t) {
        const Triangle& tri = mesh_->triangles[t];
        for (int a = 0; a < 3; ++a) rhs->template segment<3>(3 * tri[a]) += gradient_[t].template segment<3>(3 * a);
      }
    } else {
      (void)x;
      (void)rhs;
    }
  }

  EvalResult evaluate(const VectorX& x, const EvalRequest& request) override {
    const Index m = static_cast<Index>(mesh_->triangles.size());
    const bool wantGradient = request.gradient != nullptr;
    const bool wantHessian = request.hessian != nullptr;
    const bool project = request.hessianMode == HessianMode::Projected;
#pragma omp parallel for schedule(static) if (m >= kParallelElementThreshold)
    for (Index t = 0; t < m; ++t) {
      const DefGrad<D> F = deformationGradient<D>(*mesh_, *rest_, x, t);
      const DefGrad<D>& T = frames_[t];
      const double area = rest_->restArea[t];
      inDomain_[t] = model_.template inDomain<D>(F);
      if (!inDomain_[t]) continue;
      if (request.energy) energy_[t] = area * model_.template psi<D>(F, T);
      if (wantGradient) {
        gradient_[t] = membraneElementGradient<D>(area, model_.template pk1<D>(F, T),
                                                  rest_->shapeGradients[t]);
      }
      if (wantHessian) {
        const StressHessian<D> H = project ? model_.template projectedHessian<D>(F, T)
                                           : model_.template hessian<D>(F, T);
        hessian_[t] = membraneElementHessian<D>(area, H, rest_->shapeGradients[t]);
      }
    }
    // Fixed-order reduction: identical results for any thread count.
    EvalResult result;
    for (Index t = 0; t < m; ++t) {
      if (!inDomain_[t]) {
        if (result.inDomain) result.firstBadElement = t;
        result.inDomain = false;
        continue;
      }
      if (request.energy) result.energy += energy_[t];
      const Triangle& tri = mesh_->triangles[t];
      if (wantGradient) {
        for (int a = 0; a < 3; ++a) {
          request.gradient->template segment<D>(D * tri[a]) +=
              gradient_[t].template segment<D>(D * a);
        }
      }
      if (wantHessian) {
        request.hessian->addElement<3 * D>(hessian_[t], &offsets_[static_cast<std::size_t>(t) * 9 * D]);
      }
    }
    if (!result.inDomain) result.energy = kInfiniteEnergy;
    return result;
  }

 private:
  std::shared_ptr<const Mesh> mesh_;
  std::shared_ptr<const RestState> rest_;
  Model model_;
  std::vector<DefGrad<D>, Eigen::aligned_allocator<DefGrad<D>>> frames_;
  std::vector<double> energy_;
  std::vector<char> inDomain_;
  std::vector<ElementVector<D>, Eigen::aligned_allocator<ElementVector<D>>> gradient_;
  std::vector<ElementMatrix<D>, Eigen::aligned_allocator<ElementMatrix<D>>> hessian_;
  std::vector<int> offsets_;
  VertexIncidence incidence_;  // the triangles of each vertex (prepareVertexAccess)
};

template <int D>
std::unique_ptr<EnergyTerm> makeForDim(std::shared_ptr<const Mesh> mesh,
                                       std::shared_ptr<const RestState> rest,
                                       const Material& material) {
  return std::visit(
      [&](const auto& model) -> std::unique_ptr<EnergyTerm> {
        using Model = std::decay_t<decltype(model)>;
        return std::make_unique<MembraneTerm<D, Model>>(mesh, rest, model);
      },
      material);
}

template <int D>
double minAreaRatioFor(const Mesh& mesh, const RestState& rest, const VectorX& x, Index* where) {
  double best = std::numeric_limits<double>::infinity();
  for (Index t = 0; t < mesh.numTriangles(); ++t) {
    const double J = areaRatio(deformationGradient<D>(mesh, rest, x, t));
    if (J < best || (t == 0 && !(J == J))) {
      best = J;
      if (where != nullptr) *where = t;
    }
  }
  return best;
}

}  // namespace

std::unique_ptr<EnergyTerm> makeMembraneTerm(std::shared_ptr<const Mesh> mesh,
                                             std::shared_ptr<const RestState> rest,
                                             const Material& material) {
  if (mesh->dim == 2) return makeForDim<2>(std::move(mesh), std::move(rest), material);
  return makeForDim<3>(std::move(mesh), std::move(rest), material);
}

double minAreaRatio(const Mesh& mesh, const RestState& rest, const VectorX& x, Index* where) {
  if (mesh.dim == 2) return minAreaRatioFor<2>(mesh, rest, x, where);
  return minAreaRatioFor<3>(mesh, rest, x, where);
}

}  // namespace fem_cloth
