// The incremental potential and its terms (core/potential/): per-vertex access (force and 3x3
// Hessian block) against central differences of the term's energy and against the rows and
// blocks of its global gradient and Hessian, and dPhi/dx against central differences of Phi.
#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "fem_cloth/core/potential/incremental_potential.h"
#include "fem_cloth/core/potential/terms.h"
#include "test_support.h"

using namespace fem_cloth;
using namespace fem_cloth::test;

namespace {

constexpr double kStep = 1e-5;  // m, central differences of first derivatives
// m, of second derivatives: central second differences are exact for the (at most quadratic)
// terms checked here at any step, so a long one keeps the round-off of E / step^2 small.
constexpr double kHessianStep = 1e-3;

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

double energy(PotentialTerm& term, const VectorX& x) {
  TermRequest request;
  return term.evaluate(x, request).energy;
}

VectorX gradient(PotentialTerm& term, const VectorX& x) {
  VectorX g = VectorX::Zero(x.size());
  TermRequest request;
  request.energy = false;
  request.gradient = &g;
  term.evaluate(x, request);
  return g;
}

// Checks the term's per-vertex derivatives at every vertex against central differences of its
// energy and against its global gradient and Hessian (dense, from the Model's pattern; a
// mass-proportional Hessian k M on the diagonal).
void checkVertexAccess(PotentialTerm& term, Model& model, const VectorX& x) {
  ASSERT_TRUE(term.capabilities().perVertex) << term.name();
  SparseHessian& pattern = model.hessianPattern();
  pattern.setZero();
  TermRequest request;
  request.energy = false;
  request.hessian = &pattern;
  term.evaluate(x, request);
  Eigen::MatrixXd H = Eigen::MatrixXd(pattern.matrix());
  H.diagonal() += term.massProportionalHessian() * model.dofMasses();
  const VectorX g = gradient(term, x);
  const double scale = std::max(g.cwiseAbs().maxCoeff(), 1e-12);
  const double hScale = std::max(H.cwiseAbs().maxCoeff(), 1e-12);
  // Round-off of the differences: of E (its size at x) over the steps.
  const double eps = std::numeric_limits<double>::epsilon();
  const double e0 = std::abs(energy(term, x)) + 1e-30;
  const double forceNoise = 1e2 * eps * e0 / kStep;
  const double blockNoise = 1e2 * eps * e0 / (kHessianStep * kHessianStep);
  double worstForce = 0.0, worstBlock = 0.0, worstRow = 0.0, worstGlobalBlock = 0.0;
  for (Index v = 0; v < model.numVertices(); ++v) {
    VertexDerivatives d;
    ASSERT_TRUE(term.vertexDerivatives(x, v, HessianMode::Exact, d)) << term.name();
    for (int a = 0; a < 3; ++a) {
      VectorX xp = x, xm = x;
      xp[3 * v + a] += kStep;
      xm[3 * v + a] -= kStep;
      const double fd = -(energy(term, xp) - energy(term, xm)) / (2.0 * kStep);
      worstForce = std::max(worstForce, std::abs(d.force[a] - fd));
      worstRow = std::max(worstRow, std::abs(d.force[a] + g[3 * v + a]));
      for (int b = 0; b < 3; ++b) {
        // d^2E / dx_a dx_b from central differences of the energy.
        auto at = [&](double sa, double sb) {
          VectorX y = x;
          y[3 * v + a] += sa;
          y[3 * v + b] += sb;
          return energy(term, y);
        };
        const double e = kHessianStep;
        const double fdH = (at(e, e) - at(e, -e) - at(-e, e) + at(-e, -e)) / (4.0 * e * e);
        worstBlock = std::max(worstBlock, std::abs(d.hessian(a, b) - fdH));
        worstGlobalBlock =
            std::max(worstGlobalBlock, std::abs(d.hessian(a, b) - H(3 * v + a, 3 * v + b)));
      }
    }
  }
  std::cout << term.name() << ": force vs differences " << worstForce / scale
            << ", vs gradient row " << worstRow / scale << "; block vs differences "
            << worstBlock / hScale << ", vs Hessian block " << worstGlobalBlock / hScale
            << " (relative; round-off of the differences " << forceNoise << " N, " << blockNoise
            << " N/m)\n";
  EXPECT_LT(worstForce, 1e-6 * scale + forceNoise) << term.name();
  EXPECT_LT(worstRow, 1e-12 * scale) << term.name();
  EXPECT_LT(worstBlock, 1e-6 * hScale + blockNoise) << term.name();
  EXPECT_LT(worstGlobalBlock, 1e-12 * hScale) << term.name();
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
  checkVertexAccess(p.loads, model, x);
  checkVertexAccess(p.massDamping, model, x);
  checkVertexAccess(p.stiffnessDamping, model, x);
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
