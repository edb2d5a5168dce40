// The incremental potential and its terms (core/potential/): per-vertex access of the loads and
// the damping (force and 3x3 Hessian block, checkVertexAccess of vertex_access_check.h: against
// central differences of the term's energy and gradient and against the rows and blocks of its
// global gradient and Hessian), and dPhi/dx against central differences of Phi.
#include <gtest/gtest.h>

#include <random>

#include "fem_cloth/core/potential/incremental_potential.h"
#include "fem_cloth/core/potential/terms.h"
#include "test_support.h"
#include "vertex_access_check.h"

using namespace fem_cloth;
using namespace fem_cloth::test;

namespace {

constexpr double kStep = 1e-5;  // m, central differences

struct Fixture {
  Simulation sim;
  State state;
  std::vector<char> pinned;
  VectorX gravity, external;
};

// A 4 x 4 sheet (0.5 m) displaced randomly by up to 5 cm, moving at up to 1 m/s, with a BDF2
// history one step back: every coefficient of Phi is non-trivial.
Fixture makeFixture() {
  Fixture f{mustBuild(gridScene(3, 4, 0.5, "bdf2", 100.0)), {}, {}, {}, {}};
  Model& model = f.sim.simulator->model();
  const Index n = model.numDofs();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto random = [&](double scale) {
    VectorX r(n);
    for (Index i = 0; i < n; ++i) r[i] = scale * u(rng);
    return r;
  };
  f.state.x = model.mesh().restPositions + random(0.05);
  f.state.v = random(1.0);
  f.state.xPrevious = f.state.x - 0.01 * f.state.v + random(1e-3);
  f.state.vPrevious = f.state.v + random(0.1);
  f.state.historyDt = 0.01;
  f.pinned.assign(static_cast<std::size_t>(n), 0);
  f.gravity = VectorX::Zero(n);
  for (Index i = 0; i < model.numVertices(); ++i) f.gravity[3 * i + 2] = -kG * model.vertexMasses()[i];
  f.external = random(0.1);
  return f;
}

// Phi of the fixture for `scheme` over h = 0.01 s with the Model's terms (if `elastic`), the loads,
// mass damping alpha = 0.7/s and stiffness damping beta = 0.02 s.
struct Potential {
  IncrementalPotential phi;
  ElasticTerm elastic;
  LoadTerm loads;
  MassDampingTerm massDamping;
  StiffnessDampingTerm stiffnessDamping;
  Potential(Fixture& f, ImplicitScheme scheme, bool withElastic) {
    Model& model = f.sim.simulator->model();
    phi.beginSubstep(scheme, f.state, 0.01, 3, model.dofMasses(), f.pinned, 0.0, 1.0);
    elastic.bind(model);
    loads.setForces(f.gravity, f.external);
    massDamping.configure(0.7, model.dofMasses());
    stiffnessDamping.configure(0.02, model);
    if (withElastic) phi.addTerm(elastic);
    phi.addTerm(loads);
    phi.addTerm(massDamping);
    phi.addTerm(stiffnessDamping);
  }
};

// The check of a term's per-vertex access (vertex_access_check.h), its Hessian assembled in the
// Model's pattern (which the stiffness damping's lagged K0 is in) with its mass-proportional
// part on the diagonal. The differences are exact for these (at most quadratic) terms up to
// round-off: the block is held to 1e-6.
Probe probeOf(PotentialTerm& term, Model& model) {
  // The Model owns its pattern: an aliasing, non-owning pointer to it.
  std::shared_ptr<SparseHessian> pattern(std::shared_ptr<SparseHessian>(), &model.hessianPattern());
  Probe p = test::probeOf<TermRequest>(term, pattern, 3, &model.dofMasses());
  p.step = kStep;
  p.blockTolerance = 1e-6;
  return p;
}

}  // namespace

TEST(PotentialTerms, PerVertexAccessMatchesDifferencesAndGlobalDerivatives) {
  Fixture f = makeFixture();
  Model& model = f.sim.simulator->model();
  Potential p(f, ImplicitScheme::Bdf2, false);
  ASSERT_TRUE(p.phi.isBdf2());
  p.phi.prepareVertexAccess();
  // Away from the start, so that the lagged terms' velocities are not zero.
  const VectorX x = f.state.x + 0.01 * f.state.v;
  for (PotentialTerm* term : p.phi.terms()) {
    EXPECT_TRUE(term->capabilities().perVertex) << term->name();
    checkVertexAccess(probeOf(*term, model), x);
  }
}

// dPhi/dx against central differences of Phi, for backward Euler and BDF2, with every term a
// scene without contact and air can have.
TEST(IncrementalPotential, GradientMatchesDifferencesOfPhi) {
  for (ImplicitScheme scheme : {ImplicitScheme::BackwardEuler, ImplicitScheme::Bdf2}) {
    Fixture f = makeFixture();
    Potential p(f, scheme, true);
    IncrementalPotential& potential = p.phi;
    EXPECT_EQ(potential.isBdf2(), scheme == ImplicitScheme::Bdf2);
    // The scheme's coefficients (incremental_potential.h).
    EXPECT_DOUBLE_EQ(potential.c2(), scheme == ImplicitScheme::Bdf2 ? 4.0 / 9.0 * 1e-4 : 1e-4);
    const VectorX x = f.state.x + 0.01 * f.state.v;
    auto phi = [&](const VectorX& y) { return potential.value(y, potential.evaluateTerms(y, nullptr)); };
    VectorX termGradient, g;
    potential.evaluateTerms(x, &termGradient);
    potential.gradient(x, termGradient, g);
    double worst = 0.0;
    for (Index i = 0; i < x.size(); ++i) {
      VectorX xp = x, xm = x;
      xp[i] += kStep;
      xm[i] -= kStep;
      worst = std::max(worst, std::abs(g[i] - (phi(xp) - phi(xm)) / (2.0 * kStep)));
    }
    const double scale = g.cwiseAbs().maxCoeff();
    std::cout << (scheme == ImplicitScheme::Bdf2 ? "bdf2" : "backward_euler")
              << ": dPhi/dx vs differences " << worst / scale << " (relative)\n";
    EXPECT_LT(worst, 1e-6 * scale);
  }
}
