// The optional solver forms of the energy terms (core/energy_forms.h): which terms offer which,
// and that a constraint form is the term's energy, U = sum_e 1/2 C_e^T K_e C_e, summed here
// from the form's own values at a deformed state and compared with the term's evaluate().
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "fem_cloth/core/bending.h"
#include "fem_cloth/core/energy_forms.h"
#include "fem_cloth/core/integrators/registry.h"
#include "fem_cloth/core/materials/materials.h"
#include "fem_cloth/core/membrane.h"
#include "fem_cloth/core/mesh.h"
#include "fem_cloth/core/rest_state.h"

namespace fem_cloth {
namespace {

struct Sheet {
  std::shared_ptr<const Mesh> mesh;
  std::shared_ptr<const RestState> rest;
};

Sheet sheet(int dim) {
  GridSpec spec;
  spec.rows = 4;
  spec.cols = 5;
  spec.width = 0.4;
  spec.height = 0.3;
  spec.dim = dim;
  Sheet s;
  s.mesh = std::make_shared<const Mesh>(*makeGrid(spec));
  s.rest = std::make_shared<const RestState>(*computeRestState(*s.mesh));
  return s;
}

std::unique_ptr<EnergyTerm> membrane(const Sheet& s, const std::string& model) {
  return makeMembraneTerm(s.mesh, s.rest, *makeMaterial(model, Lame{300.0, 200.0}));
}

std::unique_ptr<EnergyTerm> bending(const Sheet& s, const std::string& model) {
  BendingSpec spec;
  spec.model = *bendingModelFromName(model);
  spec.stiffness = 1e-3;
  return std::move(makeBendingTerm(*s.mesh, *s.rest, spec)).value();
}

// A smooth stretch, shear and out-of-plane bulge of the rest positions (no element inverted).
VectorX deformed(const Mesh& mesh) {
  VectorX x = mesh.restPositions;
  const int d = mesh.dim;
  for (Index i = 0; i < mesh.numVertices(); ++i) {
    const double a = x[d * i], b = x[d * i + 1];
    x[d * i] = 1.1 * a + 0.05 * b;
    x[d * i + 1] = 0.95 * b + 0.02 * a * a;
    if (d == 3) x[d * i + 2] = 0.1 * std::sin(3.0 * a) * std::cos(2.0 * b);
  }
  return x;
}

double constraintEnergy(const ConstraintForm& form, const VectorX& x, int dim) {
  double total = 0.0;
  const int k = form.constraintsPerElement();
  const int m = form.verticesPerElement() * dim;
  std::vector<double> C(k), G(k * m), K(k * k);
  for (Index e = 0; e < form.numElements(); ++e) {
    EXPECT_TRUE(form.elementConstraints(e, x, C.data(), G.data())) << e;
    form.elementConstraintStiffness(e, K.data());
    for (int i = 0; i < k; ++i) {
      for (int j = 0; j < k; ++j) total += 0.5 * C[i] * K[i * k + j] * C[j];
    }
  }
  return total;
}

TEST(EnergyForms, EveryMembraneHasAConstraintFormOnlyArapClothAProjectiveOne) {
  for (const std::string& model : materialNames()) {
    for (int dim : {2, 3}) {
      const Sheet s = sheet(dim);
      std::unique_ptr<EnergyTerm> term = membrane(s, model);
      ASSERT_NE(term->constraintForm(), nullptr) << model << " dim " << dim;
      EXPECT_EQ(term->projectiveForm() != nullptr, model == "arap" && dim == 3) << model << " dim " << dim;
    }
  }
}

// A model without the optional members of the constraint form (material.h).
struct WithoutConstraintForm {
  static constexpr const char* kName = "without_form";
};

TEST(EnergyForms, AMaterialsConstraintFormIsOptional) {
  static_assert(kHasConstraintForm<StVenantKirchhoff>);
  static_assert(!kHasConstraintForm<WithoutConstraintForm>);
  using Mixed = std::variant<StVenantKirchhoff, WithoutConstraintForm, Arap>;
  EXPECT_EQ(namesWithConstraintForm<Mixed>(), (std::vector<std::string>{"stvk", "arap"}));
  // The six models all have one, so XPBD takes every material (an empty list means all).
  EXPECT_EQ(materialsWithConstraintForm(), materialNames());
  const Expected<const IntegratorEntry*> xpbd = findIntegrator("xpbd");
  ASSERT_TRUE(xpbd.ok());
  EXPECT_TRUE((*xpbd)->supports.materials.empty());
}

TEST(EnergyForms, BendingFormsFollowTheModel) {
  const Sheet s = sheet(3);
  EXPECT_NE(bending(s, "quadratic")->constraintForm(), nullptr);
  EXPECT_NE(bending(s, "quadratic")->projectiveForm(), nullptr);
  EXPECT_NE(bending(s, "dihedral")->constraintForm(), nullptr);
  EXPECT_EQ(bending(s, "dihedral")->projectiveForm(), nullptr);
  EXPECT_EQ(bending(s, "midedge")->constraintForm(), nullptr);
  EXPECT_EQ(bending(s, "midedge")->projectiveForm(), nullptr);
}

TEST(EnergyForms, ConstraintFormsSumToTheTermsEnergy) {
  const Sheet s = sheet(3);
  const VectorX x = deformed(*s.mesh);
  std::vector<std::unique_ptr<EnergyTerm>> terms;
  for (const std::string& model : materialNames()) terms.push_back(membrane(s, model));
  terms.push_back(bending(s, "quadratic"));
  terms.push_back(bending(s, "dihedral"));
  for (const auto& term : terms) {
    EvalRequest request;
    const double energy = term->evaluate(x, request).energy;
    ASSERT_GT(energy, 0.0) << term->name();
    EXPECT_NEAR(constraintEnergy(*term->constraintForm(), x, 3), energy, 1e-10 * energy) << term->name();
  }
}

}  // namespace
}  // namespace fem_cloth
