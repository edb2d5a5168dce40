// Every claim docs/accuracy.md makes, checked on small cases with the report's own machinery.
// Expected values come from theory (convergence orders, closed forms of the material models),
// never from the report's outputs; bands are justified where they are set.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "fem_cloth/core/materials/materials.h"
#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/report/cases.h"
#include "fem_cloth/report/run.h"
#include "fem_cloth/report/stability.h"

using namespace fem_cloth;
using namespace fem_cloth::report;

namespace {

const AccuracyScene& scene(const std::string& name) {
  static const std::vector<AccuracyScene> small = *accuracyScenes(FEM_CLOTH_CONFIG_DIR, nullptr, true);
  static const std::vector<AccuracyScene> full = *accuracyScenes(FEM_CLOTH_CONFIG_DIR, nullptr, false);
  for (const auto* list : {&small, &full}) {
    for (const AccuracyScene& s : *list) {
      if (s.name == name) return s;
    }
  }
  throw std::runtime_error("no scene " + name);
}

RunResult runWith(const AccuracyScene& s, std::vector<std::string> overrides, double dt) {
  overrides.push_back(setting("integrator.dt", dt));
  overrides.push_back(setting("duration", s.duration));
  RunRequest request;
  request.scene = *withOverrides(s.document, overrides);
  request.duration = s.duration;
  request.sampleInterval = s.sampleInterval;
  return runScene(request);
}

// The report's reference: BDF2, tight Newton tolerance, a quarter of the CFL bound (and at
// most 1/8 of the finest tested step).
const RunResult& reference(const AccuracyScene& s) {
  static std::map<std::string, RunResult> cache;
  auto it = cache.find(s.name);
  if (it != cache.end()) return it->second;
  const double cfl = *cflBound(*withOverrides(s.document, {"integrator.name=bdf2"}));
  const double target = std::min(s.referenceDt, 0.25 * cfl);
  const double dt = s.sampleInterval / (2.0 * std::ceil(0.5 * s.sampleInterval / target));
  RunResult r = runWith(s, {"integrator.name=bdf2", "integrator.error_ratio=1e-4", "integrator.error_cap=1e-4",
                                  "integrator.error_floor=1e-9"}, dt);
  EXPECT_EQ(r.outcome, RunResult::Outcome::Completed) << r.error;
  return cache.emplace(s.name, std::move(r)).first->second;
}

struct Study {
  std::vector<double> dts, errors;  // RMS position error at the end / cloth size
  double order = 0.0;               // fitted over all dts
};

Study study(const AccuracyScene& s, const std::vector<std::string>& overrides) {
  Study out;
  const RunResult& ref = reference(s);
  for (double dt : s.dts) {
    const RunResult r = runWith(s, overrides, dt);
    EXPECT_EQ(r.outcome, RunResult::Outcome::Completed) << r.error;
    out.dts.push_back(dt);
    out.errors.push_back(positionErrors(r.samples, ref.samples, ref.dim, ref.clothSize).rmsEnd);
  }
  out.order = fittedOrder(out.dts, out.errors);
  std::cout << s.name;
  for (const std::string& o : overrides) std::cout << ' ' << o;
  std::cout << ": errors";
  for (double e : out.errors) std::cout << ' ' << e;
  std::cout << "; order " << out.order << '\n';
  return out;
}

}  // namespace

// --- Convergence orders ---------------------------------------------------------------------

// On the smooth scene every tested step resolves every mode, so each method shows its order:
// 1 for backward and symplectic Euler, 2 for BDF2, and XPBD that of backward Euler (it solves
// the backward Euler equations, Macklin et al. 2016). First-order schemes have error
// C1 h + C2 h^2: the fitted order is 1 + O(h), and the band +-0.15 admits that remainder while
// rejecting orders 0.5 and 2; the same band around 2 rejects orders 1 and 3.
TEST(Claims, OrdersShowOnTheSmoothScene) {
  const AccuracyScene& s = scene("smooth");
  EXPECT_NEAR(study(s, {"integrator.name=backward_euler"}).order, 1.0, 0.15);
  EXPECT_NEAR(study(s, {"integrator.name=bdf2"}).order, 2.0, 0.15);
  EXPECT_NEAR(study(s, {"integrator.name=symplectic_euler"}).order, 1.0, 0.15);
  EXPECT_NEAR(study(s, {"integrator.name=xpbd", "integrator.iterations=4"}).order, 1.0, 0.15);
}

// On cloth, every practical step is far above the period of the membrane modes (h omega_max > 1
// for every tested dt): the implicit methods damp those modes instead of following them, which
// the reference resolves, so they converge more slowly than their order (the damping of a mode
// with h omega >> 1 is complete whatever h), and BDF2 stays well more accurate than backward
// Euler. The bands only state "not above the nominal order" and "clearly below 2".
TEST(Claims, ImplicitMethodsArePreAsymptoticOnCloth) {
  const AccuracyScene& s = scene("hanging_cloth");
  const double omegaMax = 2.0 / *cflBound(s.document);
  for (double dt : s.dts) EXPECT_GT(dt * omegaMax, 1.0) << dt;
  const Study be = study(s, {"integrator.name=backward_euler"});
  const Study bdf2 = study(s, {"integrator.name=bdf2"});
  EXPECT_LE(be.order, 1.05);
  EXPECT_GT(be.order, 0.3);
  EXPECT_LT(bdf2.order, 1.8);
  for (std::size_t i = 0; i < be.errors.size(); ++i) {
    EXPECT_LT(2.0 * bdf2.errors[i], be.errors[i]) << "dt " << be.dts[i];
  }
}

// Symplectic Euler substeps itself below its CFL bound: its error is set by cfl_safety (first
// order in the substep: half the safety, half the error), hardly by dt. With n >= 10 substeps
// per step at every tested dt here, the substep is within 10 % of cfl_safety x the bound, so
// the error changes by less than 25 % across dt; halving the safety factor halves it (band
// 0.4-0.6 for the O(h) remainder).
TEST(Claims, SymplecticEulerErrorIsSetByItsSubstepNotByDt) {
  const AccuracyScene& s = scene("hanging_cloth");
  const double cfl = *cflBound(s.document);
  EXPECT_GE(s.dts.back() / (0.5 * cfl), 10.0);
  const Study half = study(s, {"integrator.name=symplectic_euler", "integrator.cfl_safety=0.5"});
  const Study quarter = study(s, {"integrator.name=symplectic_euler", "integrator.cfl_safety=0.25"});
  EXPECT_NEAR(half.errors.front() / half.errors.back(), 1.0, 0.25);
  for (std::size_t i = 0; i < half.errors.size(); ++i) {
    EXPECT_NEAR(quarter.errors[i] / half.errors[i], 0.5, 0.1) << "dt " << half.dts[i];
  }
}

// XPBD solves the backward Euler equations when converged (Macklin et al. 2016). Since issue 11
// it does not stop at a fixed iteration count: it sweeps on until the forces balance to 1 % of
// each vertex's weight, inertia and load (acceptance test (a)), or substeps. So the iteration
// count no longer sets its result (the earlier claim, "64 iterations are twice as close to
// backward Euler as 4", described unconverged solves that are now refused): 4, 16 and 64
// iterations end within 1 % of backward Euler's own error of each other. And since its accepted
// substeps solve backward Euler's equations at a substep no longer than dt, it is no less
// accurate than backward Euler at the same dt (5 % slack for the 1 % residual it may leave).
TEST(Claims, XpbdSolvesBackwardEulerWhateverItsIterationCount) {
  const AccuracyScene& s = scene("hanging_cloth");
  const Study be = study(s, {"integrator.name=backward_euler"});
  const Study xpbd = study(s, {"integrator.name=xpbd", "integrator.iterations=4"});
  for (std::size_t i = 0; i < be.errors.size(); ++i) {
    EXPECT_LE(xpbd.errors[i], 1.05 * be.errors[i]) << "dt " << be.dts[i];
  }
  const double dt = s.dts.back();
  const std::size_t last = be.errors.size() - 1;
  std::map<int, RunResult> runs;
  for (int iterations : {4, 16, 64}) {
    runs.emplace(iterations, runWith(s, {"integrator.name=xpbd", "integrator.iterations=" + std::to_string(iterations)}, dt));
    ASSERT_EQ(runs.at(iterations).outcome, RunResult::Outcome::Completed) << runs.at(iterations).error;
  }
  for (int iterations : {4, 16}) {
    const RunResult& x = runs.at(iterations);
    const double gap = positionErrors(x.samples, runs.at(64).samples, x.dim, x.clothSize).rmsEnd;
    std::cout << "xpbd " << iterations << " it vs 64 it at dt " << dt << ": " << gap << " (backward Euler's error "
              << be.errors[last] << ")\n";
    EXPECT_LT(gap, 0.01 * be.errors[last]) << iterations;
  }
}

// Positions of a cloth without bending stiffness are only predictable until it folds: after
// that, differences of any origin grow exponentially. The reference against itself at twice
// its step shows it: tiny early, a hundred times larger (at least) after the fold.
TEST(Claims, PositionsDivergeAfterTheClothFolds) {
  AccuracyScene s = scene("hanging_long");
  s.document = *withOverrides(s.document, {"mesh.rows=9", "mesh.cols=9"});
  const double dt = s.sampleInterval / 64.0;
  const RunResult a = runWith(s, {"integrator.name=bdf2", "integrator.error_ratio=1e-4", "integrator.error_cap=1e-4"}, dt);
  const RunResult b = runWith(s, {"integrator.name=bdf2", "integrator.error_ratio=1e-4", "integrator.error_cap=1e-4"}, 2.0 * dt);
  const PositionErrors e = positionErrors(b.samples, a.samples, a.dim, a.clothSize);
  const double early = e.rms[6], late = e.rms.back();  // t = 0.2 s and 1 s
  std::cout << "BDF2 at dt vs 2 dt: " << early << " at 0.2 s, " << late << " at 1 s\n";
  EXPECT_GT(late, 100.0 * early);
}

// --- Stability ------------------------------------------------------------------------------

namespace {

CellResult cell(const std::string& c, const std::string& material, const std::string& stiffness,
                const std::string& integrator, double dt) {
  return runCell(Cell{c, material, stiffness, integrator, dt}, 9, 120.0);
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// The integrators that take every material (projective dynamics takes ARAP cloth only).
std::vector<std::string> generalIntegrators() {
  std::vector<std::string> out;
  for (const std::string& name : integratorNames()) {
    if (name != "projective_dynamics") out.push_back(name);
  }
  return out;
}

}  // namespace

// Cells the matrix marks stable or recovered stay finite and bounded, re-run here: on the
// near-degenerate mesh at 1000x stiffness and dt = 1/30 s the implicit methods create no energy
// where no pin moves (the balance error never grows: their line search only lowers the
// incremental potential) and finish, some after rollbacks, keeping edges within 5 % of their
// length. Two cells changed with issue 11, both refusals by a test of the acceptance:
// - linear: the sagging cloth rotates its elements (the linear strain (F + F^T)/2 - I is not
//   rotation invariant), |F - T| reaches ~0.2, twice the model's validity limit 0.1 (test c);
//   it used to be accepted with an extra stretch that no material has;
// - Neo-Hookean: on the slivers (quality 1e-5) at 1000x stiffness it used to be accepted after a
//   short last Newton step with the forces unbalanced. With acceptance (a) in displacement (issue
//   29) BDF2 completes (the forces left move the slivers by less than the tolerance), and either
//   integrator is held to the same bounds as the other materials when it does.
// - Backward Euler on Neo-Hookean there balances or refuses depending on round-off: its projected
//   Newton steps, shorter than the tolerance, alternate between forces of ~700 and ~18000 times a
//   vertex's force scale on the compressed slivers (the clamped Hessian is not the energy's), and
//   whether a cycle breaks depends on the last bits of the linear solve (measured 2026-12:
//   balanced with CHOLMOD's supernodal factor, refused after 4 rollbacks with the simplicial one,
//   and either way with one step of iterative refinement at different thresholds). Either
//   outcome is allowed; a refusal must name the unbalanced force and keep the state.
// Symplectic Euler on the whip (a pin at 100 m/s) creates no energy beyond 5 % of the run's scale
// (acceptance b over the run; it used to end "wrong", 30 % created).
TEST(Claims, StableCellsStayFiniteAndBounded) {
  for (const std::string integrator : {"backward_euler", "bdf2"}) {
    for (const std::string& material : materialNames()) {
      const CellResult r = cell("degenerate", material, "1000x", integrator, 1.0 / 30.0);
      if (material == "linear") {
        EXPECT_EQ(r.verdict, "failed") << integrator;
        EXPECT_TRUE(contains(r.run.error, "outside the validity range") && contains(r.run.error, "|F - T|"))
            << r.run.error;
        continue;
      }
      if (material == "neo_hookean" && r.verdict == "failed") {
        EXPECT_TRUE(contains(r.run.error, "Newton did not converge") && contains(r.run.error, "unbalanced force") &&
                    contains(r.run.error, "the state is unchanged"))
            << r.run.error;
        EXPECT_LE(r.run.energyGrowth, 1e-6) << integrator << " " << material;
        continue;
      }
      EXPECT_TRUE(r.verdict == "stable" || r.verdict == "recovered")
          << integrator << " " << material << ": " << r.run.error;
      EXPECT_LE(r.run.energyGrowth, 1e-6) << integrator << " " << material;
      EXPECT_LT(r.run.maxStretch, 0.05) << integrator << " " << material;
    }
  }
  for (const std::string& integrator : generalIntegrators()) {
    const CellResult r = cell("whip", "stable_neo_hookean", "cotton", integrator, 1e-3);
    EXPECT_TRUE(r.verdict == "stable" || r.verdict == "recovered") << integrator << ": " << r.run.error;
    EXPECT_LE(r.run.energyGrowth, kWrongEnergyGrowth) << integrator;
    EXPECT_TRUE(std::isfinite(r.run.maxStretch));
  }
}

// Neo-Hookean's energy is infinite at J <= 0: squashing a sheet to zero area is refused with an
// error naming the material's domain, by every implicit integrator (symplectic Euler stops
// earlier, at its substep limit, naming the stable step); starting inverted is a scene error.
TEST(Claims, NeoHookeanRefusesZeroAreaWithAClearError) {
  for (const std::string& integrator : generalIntegrators()) {
    const CellResult r = cell("squash", "neo_hookean", "cotton", integrator, 1e-2);
    EXPECT_EQ(r.verdict, "failed") << integrator;
    // Symplectic Euler meets the stiffening first: its stable step shrinks with J.
    EXPECT_TRUE(contains(r.run.error, "domain") || contains(r.run.error, "J <= 0") ||
                (integrator == "symplectic_euler" && contains(r.run.error, "stable step")))
        << r.run.error;
    const CellResult start = cell("inverted", "neo_hookean", "cotton", integrator, 1e-2);
    EXPECT_EQ(start.verdict, "failed") << integrator;
    EXPECT_TRUE(contains(start.run.error, "outside the material's domain")) << start.run.error;
  }
}

// A reflection F = diag(-1, 1) has F^T F = I: StVK (E = (F^T F - I) / 2) sees no strain in it and
// keeps the folded half exactly, with every integrator; every other model pushes it back.
TEST(Claims, StvkKeepsAFoldItCannotSee) {
  for (const std::string& integrator : generalIntegrators()) {
    const CellResult r = cell("inverted", "stvk", "cotton", integrator, 1e-2);
    EXPECT_EQ(r.verdict, "stable") << integrator << ": " << r.run.error;
    EXPECT_NEAR(r.run.minJEnd, -1.0, 1e-9) << integrator;
    EXPECT_LT(r.run.maxStretch, 1e-9) << integrator;
  }
  const CellResult snh = cell("inverted", "stable_neo_hookean", "cotton", "backward_euler", 1e-2);
  EXPECT_EQ(snh.verdict, "stable") << snh.run.error;
  EXPECT_GT(snh.run.minJEnd, -1.0 + 1e-3);
}

// Symplectic Euler refuses a step that would need more than 65536 substeps and says which
// stable step the scene has: the slivers of the degenerate case make it tiny.
TEST(Claims, SymplecticEulerRefusesSliversWithTheStableStep) {
  const CellResult r = cell("degenerate", "stvk", "100x", "symplectic_euler", 1.0 / 30.0);
  EXPECT_EQ(r.verdict, "failed");
  EXPECT_TRUE(contains(r.run.error, "substeps") && contains(r.run.error, "stable step")) << r.run.error;
}

// Corotational cloth: psi = mu sum (s_i - 1)^2 + lambda/2 (s1 + s2 - 2)^2 with s2 >= 0 for a
// 3 x 2 F, so d psi / d s2 at s2 = 0 is -2 mu + lambda (s1 - 2): positive once the element is
// stretched beyond s1 = 2 + 2 mu / lambda. There the energy is smallest with the element
// collapsed onto a line, where s2 = |t| makes it a kink: Newton cannot converge on it and the
// implicit steps fail with a clear error. ARAP (no lambda term, slope -2 mu) has no such kink.
TEST(Claims, CorotationalClothCollapsesIntoAKinkUnderLargeStretch) {
  const Lame lame = Lame::fromYoungPoisson(2.0e7 * 5e-4, 0.3);
  const double s1 = 2.0 + 2.0 * lame.mu / lame.lambda + 0.5;
  const Material corotational = *makeMaterial("corotational", lame);
  const Material arap = *makeMaterial("arap", lame);
  auto psiAt = [&](const Material& m, double t) {
    DefGrad<3> F = DefGrad<3>::Zero(), restFrame = DefGrad<3>::Zero();
    F(0, 0) = s1;
    F(1, 1) = t;  // the second column of F crossing zero: the element folds over
    restFrame(0, 0) = restFrame(1, 1) = 1.0;
    return std::visit([&](const auto& model) { return model.template psi<3>(F, restFrame); }, m);
  };
  const double eps = 1e-4;
  for (double t : {eps, -eps}) {
    EXPECT_GT(psiAt(corotational, t), psiAt(corotational, 0.0));  // a minimum at the fold...
    EXPECT_LT(psiAt(arap, t), psiAt(arap, 0.0));                   // ...which ARAP pushes open
  }
  // ...and a kink: the rise is linear in |t| (doubling t doubles it), not quadratic.
  const double rise1 = psiAt(corotational, eps) - psiAt(corotational, 0.0);
  const double rise2 = psiAt(corotational, 2 * eps) - psiAt(corotational, 0.0);
  EXPECT_NEAR(rise2 / rise1, 2.0, 0.01);
  for (const std::string integrator : {"backward_euler", "bdf2"}) {
    const CellResult r = cell("pull_corner", "corotational", "cotton", integrator, 1e-2);
    EXPECT_EQ(r.verdict, "failed") << integrator;
    EXPECT_TRUE(contains(r.run.error, "line search") || contains(r.run.error, "Newton did not converge"))
        << r.run.error;
    EXPECT_GT(r.run.maxStretch, s1 - 1.0 - 0.5) << "the failure comes with the large stretch";
    const CellResult a = cell("pull_corner", "arap", "cotton", integrator, 1e-2);
    EXPECT_TRUE(a.verdict == "stable" || a.verdict == "recovered") << integrator << ": " << a.run.error;
  }
}

// A bug the matrix used to show, fixed by issue 11: the simulator bounded the work of the pins in
// a step with their end-of-step forces (and booked it with the trapezoid rule). When a pin drags
// the cloth at 100 m/s the force comes early in the step, so symplectic Euler's substeps at
// dt = 1/30 s were refused as a "blow-up" although they were right, and the pin work booked
// without the guard was off by more than half. Every integrator now books each substep's pin
// force along that substep's pin displacement (StepReport::pinWork): the run at 1/30 s is
// accepted with the energy test on, ends where the dt = 1e-3 s run ends, and books the same pin
// work (measured 3.5 % apart; 10 % asserted).
TEST(Claims, AFastPinsWorkIsBookedPerSubstep) {
  auto whip = [](double dt) {
    Expected<Scene> scene = parseScene(*cellScene(Cell{"whip", "stvk", "cotton", "symplectic_euler", dt}, 9));
    Simulation sim = std::move(buildSimulation(*scene)).value();
    EXPECT_TRUE(sim.simulator->settings().acceptance.energy);
    sim.simulator = std::make_unique<Simulator>(sim.model, std::make_unique<SymplecticEuler>(),
                                                sim.simulator->settings());
    const Eigen::Vector3d velocity = scene->pins[0].velocity;
    EXPECT_TRUE(sim.simulator->pin(0, Eigen::Vector3d::Zero(), velocity).ok());
    VectorX v = VectorX::Zero(sim.model->numDofs());
    v.head<3>() = velocity;
    EXPECT_TRUE(sim.simulator->setInitialState(sim.mesh->restPositions, v).ok());
    std::string error;
    for (int k = 0; k < static_cast<int>(std::lround(scene->duration / dt)) && error.empty(); ++k) {
      const StepReport r = sim.simulator->step();
      if (!r.ok) error = r.error;
    }
    return std::make_pair(error, std::move(sim));
  };
  auto [fineError, fine] = whip(1e-3);
  ASSERT_EQ(fineError, "");
  auto [coarseError, coarse] = whip(1.0 / 30.0);
  ASSERT_EQ(coarseError, "");
  // Centre of mass height: the same to 1 % of the 10 m the pin travelled.
  auto meanZ = [](const Simulation& s) {
    double z = 0.0;
    for (Index i = 0; i < s.mesh->numVertices(); ++i) z += s.simulator->state().x[3 * i + 2];
    return z / static_cast<double>(s.mesh->numVertices());
  };
  EXPECT_NEAR(meanZ(coarse), meanZ(fine), 0.1);
  // The energy the cloth holds is the same to 20 %, and so is the pin work booked, to 10 %.
  const EnergyReport e1 = fine.simulator->energies(), e2 = coarse.simulator->energies();
  EXPECT_NEAR(e2.kinetic + e2.strain, e1.kinetic + e1.strain, 0.2 * (e1.kinetic + e1.strain));
  EXPECT_NEAR(e2.pinWork, e1.pinWork, 0.1 * std::abs(e1.pinWork));
}

// Inversion-aware corotational and ARAP energies (Irving et al. 2004) negate the smaller signed
// singular value of an inverted F. At a pure reflection F = diag(-1, 1) both are 1, and which
// one is negated switches there: along F = diag(-1, 1 + t) corotational's slope jumps from
// 4 mu + 2 lambda (t < 0) to -2 lambda (t > 0), a ridge on which Newton cannot converge when
// the step is small enough to stay near it. The inverted case starts its folded half exactly on
// it: the implicit steps fail there at small dt with a clear error.
TEST(Claims, InversionAwareModelsHaveARidgeAtAPureReflection) {
  const Lame lame = Lame::fromYoungPoisson(2.0e7 * 5e-4, 0.3);
  const Material corotational = *makeMaterial("corotational", lame);
  auto psiAt = [&](double t) {
    DefGrad<2> F = DefGrad<2>::Zero();
    F(0, 0) = -1.0;
    F(1, 1) = 1.0 + t;
    return std::visit([&](const auto& model) { return model.template psi<2>(F, DefGrad<2>::Identity()); },
                      corotational);
  };
  const double eps = 1e-6;
  const double left = (psiAt(0.0) - psiAt(-eps)) / eps, right = (psiAt(eps) - psiAt(0.0)) / eps;
  EXPECT_NEAR(left, 4.0 * lame.mu + 2.0 * lame.lambda, 1e-3 * lame.mu);
  EXPECT_NEAR(right, -2.0 * lame.lambda, 1e-3 * lame.mu);
  for (const std::string material : {"corotational", "arap"}) {
    // At the small step Newton's iterates straddle the ridge, where the force jumps and never
    // balances; the displacement test (acceptance (a)) accepts an iterate within its tolerance
    // of the minimum on the ridge. So either a clear refusal or a run that creates no energy
    // (measured 2026-12, issue 29: corotational completes after 4 rollbacks, its edges stretched
    // up to 160 % while the inverted half's stored energy is released, against 11 % at dt 1e-2
    // where backward Euler damps it; ARAP still refuses).
    const CellResult r = cell("inverted", material, "cotton", "backward_euler", 1e-3);
    if (r.verdict == "failed") {
      EXPECT_TRUE(contains(r.run.error, "Newton did not converge") || contains(r.run.error, "line search"))
          << r.run.error;
    } else {
      EXPECT_TRUE(r.verdict == "stable" || r.verdict == "recovered") << material << ": " << r.verdict << " " << r.run.error;
      EXPECT_LE(r.run.energyGrowth, 1e-6) << material;
    }
    // With larger steps the elastic force carries the step off the ridge.
    const CellResult large = cell("inverted", material, "cotton", "backward_euler", 1e-2);
    EXPECT_EQ(large.verdict, "stable") << material << ": " << large.run.error;
  }
}

// --- Projective dynamics --------------------------------------------------------------------

// Projective dynamics minimises backward Euler's incremental potential by local/global
// iterations, each of which lowers it (Bouaziz et al. 2014, sec. 4). Since issue 11 it goes on
// from there (quasi-Newton on the true gradient) until acceptance test (a) holds, so
// integrator.iterations no longer sets the result: with 5, 10 or 20 it ends at backward Euler's
// solution of the same step. (The earlier claim, "more iterations come closer to backward Euler;
// unconverged the cloth is softer", described unbalanced states that are now refused.) Bound: a
// quarter of backward Euler's own error against the reference, what test (a) in displacement
// promises at its default (issue 29; docs/integrators.md, Convergence); measured 0.015-0.075 x.
// Checked on the small hanging_arap scene at dt = 1/60 s.
TEST(Claims, ProjectiveDynamicsEndsAtBackwardEulerWhateverItsIterations) {
  const AccuracyScene& s = scene("hanging_arap");
  const double dt = 1.0 / 60.0;
  const RunResult& ref = reference(s);
  const RunResult be = runWith(s, {"integrator.name=backward_euler", "integrator.error_ratio=1e-4", "integrator.error_cap=1e-4"}, dt);
  ASSERT_EQ(be.outcome, RunResult::Outcome::Completed) << be.error;
  const double beError = positionErrors(be.samples, ref.samples, ref.dim, ref.clothSize).rmsEnd;
  for (int iterations : {5, 10, 20}) {
    const RunResult pd = runWith(s, {"integrator.name=projective_dynamics",
                                     "integrator.iterations=" + std::to_string(iterations)}, dt);
    ASSERT_EQ(pd.outcome, RunResult::Outcome::Completed) << pd.error;
    const double gap = positionErrors(pd.samples, be.samples, be.dim, be.clothSize).rmsEnd;
    const double error = positionErrors(pd.samples, ref.samples, ref.dim, ref.clothSize).rmsEnd;
    std::cout << "pd " << iterations << " it: gap to backward Euler " << gap << ", error " << error
              << " (backward Euler " << beError << ")\n";
    EXPECT_LT(gap, 0.25 * beError) << iterations;
    EXPECT_NEAR(error, beError, 0.25 * beError) << iterations;
  }
}

// Projective dynamics takes ARAP cloth only: its cells with any other material, or on the
// planar cases, are n/a with the load error naming what it needs, not failures.
TEST(Claims, ProjectiveDynamicsCellsAreNotApplicableOutsideArapCloth) {
  const CellResult stvk = cell("whip", "stvk", "cotton", "projective_dynamics", 1e-2);
  EXPECT_EQ(stvk.verdict, "n/a");
  EXPECT_TRUE(contains(stvk.run.error, "arap")) << stvk.run.error;
  const CellResult planar = cell("squash", "arap", "cotton", "projective_dynamics", 1e-2);
  EXPECT_EQ(planar.verdict, "n/a");
  EXPECT_TRUE(contains(planar.run.error, "dim 3")) << planar.run.error;
}

// Projective dynamics' global step is a constant SPD solve and its local step a projection
// (Bouaziz et al. 2014): its iterations cannot diverge, which the matrix used to count as
// "stable" on every ARAP cell. But on the stiffest, coarsest cells (1000x, dt = 1/30 s) they
// stopped far from balance — an unbalanced force of hundreds of times a vertex's weight, a state
// no physics produces. Since issue 11 such a step is refused (acceptance test (a)), after
// substeps, naming what is left; the stable verdict is kept for where PD converges. Since issue 29
// test (a) is backward Euler's, in displacement: the degenerate cell and the whip are still
// refused; pull_corner now converges (up to 500 quasi-Newton iterations per substep, where
// backward Euler's 50 Newton iterations do not) and is judged by the matrix's checks like every
// completed cell (no energy created).
TEST(Claims, ProjectiveDynamicsRefusesWhatItCannotBalance) {
  for (const std::string c : {"degenerate", "whip"}) {
    const CellResult r = cell(c, "arap", "1000x", "projective_dynamics", 1.0 / 30.0);
    EXPECT_EQ(r.verdict, "failed") << c;
    EXPECT_TRUE(contains(r.run.error, "not converged") && contains(r.run.error, "unbalanced force"))
        << c << ": " << r.run.error;
  }
  const CellResult pulled = cell("pull_corner", "arap", "1000x", "projective_dynamics", 1.0 / 30.0);
  EXPECT_TRUE(pulled.verdict == "recovered" || pulled.verdict == "stable" ||
              (pulled.verdict == "failed" && contains(pulled.run.error, "not converged")))
      << pulled.verdict << ": " << pulled.run.error;
  const CellResult strip = cell("strip", "arap", "cotton", "projective_dynamics", 1e-2);
  EXPECT_TRUE(strip.verdict == "stable" || strip.verdict == "recovered") << strip.run.error;
}

// Contact cells (slam: a cloth thrown at a floor at 10 m/s). The claims: every integrator that
// takes obstacles keeps every vertex on the floor's side at every step, at every dt of the
// matrix, and the cloth ends up stopped on it (the 10 m/s have gone into friction, damping and
// the barrier; BDF2 included, which restarts with backward Euler at the impact); projective
// dynamics, which takes no obstacles, is n/a.
// Checked here by stepping the cell's scene and reading z directly (the floor is z = 0).
TEST(Claims, ContactCellsNeverPassThroughTheFloor) {
  for (const std::string integrator : {"symplectic_euler", "backward_euler", "bdf2", "xpbd"}) {
    for (double dt : {1e-2, 1.0 / 30.0}) {
      Expected<YAML::Node> doc = cellScene(Cell{"slam", "stvk", "cotton", integrator, dt}, 5);
      ASSERT_TRUE(doc.ok()) << doc.error();
      Expected<Scene> scene = parseScene(*doc);
      ASSERT_TRUE(scene.ok()) << scene.error();
      Expected<Simulation> sim = buildSimulation(*scene);
      ASSERT_TRUE(sim.ok()) << sim.error();
      Simulator& s = *sim->simulator;
      double lowest = 1.0;
      const int steps = static_cast<int>(std::lround(scene->duration / dt));
      for (int k = 0; k < steps; ++k) {
        const StepReport r = s.step();
        ASSERT_TRUE(r.ok) << integrator << " dt " << dt << ": " << r.error;
        const Eigen::Map<const Eigen::Matrix3Xd> x(s.state().x.data(), 3, s.model().numVertices());
        lowest = std::min(lowest, x.row(2).minCoeff());
      }
      const Eigen::Map<const Eigen::Matrix3Xd> v(s.state().v.data(), 3, s.model().numVertices());
      const Eigen::Map<const Eigen::Matrix3Xd> x(s.state().x.data(), 3, s.model().numVertices());
      std::cout << integrator << " dt " << dt << ": lowest z " << lowest << " m, final z up to "
                << x.row(2).maxCoeff() << " m, |v_z| up to " << v.row(2).cwiseAbs().maxCoeff()
                << " m/s\n";
      EXPECT_GE(lowest, 0.0) << integrator << " dt " << dt;
      // Landed: of the 10 m/s towards the floor, under 1 % is left, and nothing bounced up.
      EXPECT_LT(v.row(2).cwiseAbs().maxCoeff(), 0.1) << integrator << " dt " << dt;
      EXPECT_LT(x.row(2).maxCoeff(), 0.01) << integrator << " dt " << dt;
    }
  }
  const CellResult pd = cell("slam", "arap", "cotton", "projective_dynamics", 1e-2);
  EXPECT_EQ(pd.verdict, "n/a");
  EXPECT_TRUE(contains(pd.run.error, "obstacles")) << pd.run.error;
}
