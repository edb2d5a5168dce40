// Convergence order of the time integrators on a smooth problem.
//
// A free planar StVK sheet (no gravity, no damping, no pins) is released from rest with a smooth
// initial stretch of up to about 25 % strain; StVK's forces are polynomial in x, so the exact
// trajectory is smooth and a scheme of order p has end-position error C h^p + O(h^(p+1)). The
// reference is an independent classical Runge-Kutta (RK4, order 4) integration written here on
// the model's elastic gradient (checked against finite differences in test_membrane) with a
// step 8x smaller than the finest tested one, cross-checked against BDF2 at T/2560.
//
// The final time T = 0.25 s is chosen against the stiffest mode of the 4 x 4 sheet, so that
// every tested step lies in the asymptotic range: backward Euler damps a mode of angular
// frequency w by about exp(-h w^2 T / 2), which is linear in h only while h w^2 T << 1. At
// T = 1 s the same sheet shows apparent orders near 0.4-0.6 for backward Euler at these steps
// (pre-asymptotic damping of the high modes), not a defect.
#include <gtest/gtest.h>

#include <cmath>
#include <iomanip>
#include <iostream>

#include "test_support.h"

using namespace fem_cloth;
using namespace fem_cloth::test;

namespace {

constexpr double kT = 0.25;  // s
const std::vector<int> kSteps = {20, 40, 80, 160};

Scene orderScene(const std::string& integrator, int steps) {
  Scene s = gridScene(2, 4, 1.0, integrator, 1.0);
  s.dt = kT / steps;
  // Newton stops at an unbalanced force of 1e-9 x each vertex's weight: an acceleration error
  // of 1e-8 m/s^2, whose effect on positions (~ 1e-8 T^2) is far below the smallest error
  // measured. The fine BDF2 run (h = 1e-4 s) cannot get there: the round-off of its residual,
  // m eps |x| / c^2, is 2.6e-9 x the weight; 1e-7 (positions within 1e-7 T^2 = 6e-9 m) is
  // still far below its own error.
  s.newton.tolerance = steps > 1000 ? 1e-7 : 1e-9;
  s.iterations = 100;
  return s;
}

/// x = X + a (sin(pi X) cos(pi Y / 2), sin(pi Y) cos(pi X / 2)), a = 0.08 m.
VectorX initialPositions(const Mesh& mesh) {
  VectorX x = mesh.restPositions;
  const double a = 0.08;
  for (Index i = 0; i < mesh.numVertices(); ++i) {
    const double X = x[2 * i], Y = x[2 * i + 1];
    x[2 * i] += a * std::sin(M_PI * X) * std::cos(0.5 * M_PI * Y);
    x[2 * i + 1] += a * std::sin(M_PI * Y) * std::cos(0.5 * M_PI * X);
  }
  return x;
}

/// Classical RK4 on x' = v, v' = -M^-1 dE/dx.
VectorX rk4EndPositions(int steps) {
  Simulation sim = mustBuild(orderScene("backward_euler", steps));
  Model& model = *sim.model;
  const VectorX& m = model.dofMasses();
  auto acceleration = [&](const VectorX& x) {
    VectorX g = VectorX::Zero(x.size());
    EvalRequest request;
    request.energy = false;
    request.gradient = &g;
    model.evaluate(x, request);
    return VectorX(-g.cwiseQuotient(m));
  };
  VectorX x = initialPositions(model.mesh()), v = VectorX::Zero(x.size());
  const double h = kT / steps;
  for (int k = 0; k < steps; ++k) {
    const VectorX a1 = acceleration(x);
    const VectorX v2 = v + 0.5 * h * a1, a2 = acceleration(x + 0.5 * h * v);
    const VectorX v3 = v + 0.5 * h * a2, a3 = acceleration(x + 0.5 * h * v2);
    const VectorX v4 = v + h * a3, a4 = acceleration(x + h * v3);
    x += h / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4);
    v += h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4);
  }
  return x;
}

/// End positions of the simulator; every step must be taken as one step of dt (no substeps, no
/// rollbacks), or the measured h would not be the nominal one.
VectorX simulatedEndPositions(const std::string& integrator, int steps) {
  Simulation sim = mustBuild(orderScene(integrator, steps));
  EXPECT_TRUE(sim.simulator->setInitialState(initialPositions(*sim.mesh)).ok());
  const std::string error = run(sim, steps, [&](int k, const StepReport& r) {
    EXPECT_EQ(r.substeps, 1) << integrator << " step " << k;
    EXPECT_EQ(r.rollbacks, 0) << integrator << " step " << k;
  });
  EXPECT_EQ(error, "") << integrator;
  return sim.simulator->state().x;
}

const VectorX& reference() {
  static const VectorX x = rk4EndPositions(1280);
  return x;
}

struct OrderStudy {
  std::vector<double> errors;  // max-norm end-position error per entry of kSteps (m)
  std::vector<double> orders;  // log2(e(h) / e(h/2)) per successive pair
};

OrderStudy study(const std::string& integrator) {
  OrderStudy s;
  for (int steps : kSteps) {
    s.errors.push_back(maxAbs(simulatedEndPositions(integrator, steps) - reference()));
  }
  for (std::size_t i = 1; i < s.errors.size(); ++i) {
    s.orders.push_back(std::log2(s.errors[i - 1] / s.errors[i]));
  }
  std::cout << std::setprecision(3) << integrator << ": errors (m)";
  for (double e : s.errors) std::cout << ' ' << e;
  std::cout << "; orders";
  for (double p : s.orders) std::cout << ' ' << p;
  std::cout << '\n';
  return s;
}

}  // namespace

TEST(Convergence, ReferenceIsConverged) {
  // RK4's error falls like h^4: halving its step must change the end positions by far less than
  // the smallest error measured below (~2e-5 m for BDF2 at T/160).
  EXPECT_LT(maxAbs(rk4EndPositions(2560) - reference()), 1e-10);
  // An independent scheme agrees: BDF2 at T/2560 is 16x finer than the finest tested step, so
  // its error is about 2e-5 / 256 m.
  const double bdf2Fine = maxAbs(simulatedEndPositions("bdf2", 2560) - reference());
  std::cout << "BDF2 at T/2560 vs RK4: " << bdf2Fine << " m\n";
  EXPECT_LT(bdf2Fine, 5e-7);
  // The motion is not trivially small: the sheet moves by centimetres during T.
  Simulation sim = mustBuild(orderScene("backward_euler", 1));
  EXPECT_GT(maxAbs(reference() - initialPositions(*sim.mesh)), 0.01);
}

// First-order schemes have error C1 h + C2 h^2, so the order measured from a pair (h, h/2) is
// 1 + O(h); the band +-0.1 on the finest pair admits that remainder (measured 0.99) and rejects
// both order 2 and any order below 0.9. The apparent order must also approach 1 as h falls.
TEST(Convergence, BackwardEulerIsFirstOrder) {
  const OrderStudy s = study("backward_euler");
  EXPECT_NEAR(s.orders.back(), 1.0, 0.1);
  EXPECT_LT(std::abs(s.orders.back() - 1.0), std::abs(s.orders.front() - 1.0));
}

// Second order: the band +-0.15 admits the O(h) remainder of the order estimate and of the
// first step, which BDF2 takes with backward Euler (a local error O(h^2), so the global error
// stays O(h^2)); it rejects order 1 and order 3.
TEST(Convergence, Bdf2IsSecondOrder) {
  const OrderStudy s = study("bdf2");
  for (double p : s.orders) EXPECT_NEAR(p, 2.0, 0.15);
}

TEST(Convergence, SymplecticEulerIsFirstOrder) {
  const OrderStudy s = study("symplectic_euler");
  EXPECT_NEAR(s.orders.back(), 1.0, 0.1);
}

// Converged XPBD solves the backward Euler equations (Macklin et al. 2016): with 100
// Gauss-Seidel sweeps its end positions match backward Euler's at the same step far more
// closely than either matches the exact solution, and so its order is 1.
TEST(Convergence, XpbdWithManyIterationsIsBackwardEuler) {
  const OrderStudy s = study("xpbd");
  EXPECT_NEAR(s.orders.back(), 1.0, 0.1);
  const int steps = kSteps.back();
  const VectorX be = simulatedEndPositions("backward_euler", steps);
  const double gap = maxAbs(simulatedEndPositions("xpbd", steps) - be);
  const double error = maxAbs(be - reference());
  std::cout << "XPBD vs backward Euler at T/" << steps << ": " << gap << " m (error " << error
            << " m)\n";
  EXPECT_LT(gap, 0.05 * error);
}
