// The integrator registry (core/integrators/registry.h): the entries build the integrators they
// name, and scene validation accepts and refuses exactly what the integrators' documentation
// says they simulate (the table below is written from their headers and docs, not from the
// registry), with messages that name the key and the integrators that would take the scene.
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <string>
#include <vector>

#include "fem_cloth/core/integrators/registry.h"
#include "test_support.h"

namespace fem_cloth {
namespace {

using test::gridScene;

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(IntegratorRegistry, ListsTheFiveIntegratorsInSceneFormatOrder) {
  const std::vector<std::string> expected = {"symplectic_euler", "backward_euler", "bdf2", "xpbd",
                                             "projective_dynamics"};
  EXPECT_EQ(integratorNames(), expected);
  ASSERT_EQ(integratorRegistry().size(), expected.size());
  for (const IntegratorEntry& e : integratorRegistry()) {
    EXPECT_FALSE(e.summary.empty()) << e.name;
    EXPECT_TRUE(findIntegrator(e.name).ok()) << e.name;
  }
  const Expected<const IntegratorEntry*> unknown = findIntegrator("leapfrog");
  ASSERT_FALSE(unknown.ok());
  EXPECT_TRUE(contains(unknown.error(), "'leapfrog'")) << unknown.error();
  EXPECT_TRUE(contains(unknown.error(), "symplectic_euler, backward_euler, bdf2, xpbd, projective_dynamics"))
      << unknown.error();
}

// Each entry builds the integrator of its name, and its Hessian capability is the one the
// integrator itself declares to the simulator.
TEST(IntegratorRegistry, EntriesBuildTheIntegratorTheyName) {
  for (const IntegratorEntry& e : integratorRegistry()) {
    const Scene s = gridScene(3, 3, 0.1, e.name);
    const std::unique_ptr<Integrator> integrator = e.make(s);
    ASSERT_NE(integrator, nullptr) << e.name;
    EXPECT_EQ(integrator->name(), e.name);
    EXPECT_EQ(integrator->needsHessian(), e.supports.needsHessian) << e.name;
  }
}

TEST(IntegratorRegistry, KeysAreTheCommonOnesThenEachIntegratorsOwnOnce) {
  const std::vector<std::string> expected = {
      "name", "dt", "substeps", "max_retries", "auto_substep", "cfl_safety",
      "max_newton_iterations", "newton_tolerance", "max_backtracks", "linear_solver",
      "cg_tolerance", "cg_max_iterations", "solver", "lbfgs_memory", "lbfgs_max_iterations",
      "error_ratio", "error_cap", "error_floor", "iterations", "chebyshev_rho"};
  EXPECT_EQ(integratorKeys(), expected);
}

// An integrator's own keys live in the scene's options under its name, in its own settings
// type: absent, they are that type's defaults; a copied scene owns its copy.
TEST(IntegratorRegistry, OwnKeysLiveInTheScenesOptions) {
  struct Made {
    double gain = 2.5;
    int sweeps = 3;
  };
  Scene a = gridScene(3, 3, 0.1, "backward_euler");
  EXPECT_EQ(a.integratorOptions.get<Made>("made_up").gain, 2.5);
  EXPECT_EQ(a.integratorOptions.get<Made>("made_up").sweeps, 3);
  a.integratorOptions.edit<Made>("made_up").gain = 7.0;
  Scene b = a;
  b.integratorOptions.edit<Made>("made_up").gain = 9.0;
  EXPECT_EQ(a.integratorOptions.get<Made>("made_up").gain, 7.0);
  EXPECT_EQ(b.integratorOptions.get<Made>("made_up").gain, 9.0);
  EXPECT_EQ(b.integratorOptions.get<Made>("made_up").sweeps, 3);
  // symplectic_euler's keys are its settings struct's fields: the stepper is built with them.
  a.integratorOptions.edit<SymplecticEulerSettings>("symplectic_euler").cflSafety = 1.5;
  const Status refused = validateScene(a);
  ASSERT_FALSE(refused.ok());
  EXPECT_TRUE(contains(refused.error(), "integrator.cfl_safety must be in (0, 1], got 1.5"))
      << refused.error();
}

// Scene features against integrators, as the integrators' headers state them: projective
// dynamics takes ARAP cloth in 3D with quadratic bending, mass damping and no contact; XPBD
// needs bending with a constraint form (quadratic, dihedral); self-contact is the implicit
// steppers' barrier only.
TEST(IntegratorRegistry, ValidationFollowsWhatEachIntegratorSimulates) {
  struct Feature {
    std::string name;
    std::function<void(Scene&)> ask;
    std::vector<std::string> accepting;
    std::string key;
  };
  const std::vector<Feature> features = {
      {"stvk material", [](Scene& s) { s.materialModel = "stvk"; },
       {"symplectic_euler", "backward_euler", "bdf2", "xpbd"}, "material.model"},
      {"planar mesh", [](Scene& s) { s.grid.dim = 2; s.dim = 2; s.gravity.setZero(); },
       {"symplectic_euler", "backward_euler", "bdf2", "xpbd"}, "mesh.dim"},
      {"midedge bending", [](Scene& s) { s.bendingStiffness = 1e-6; s.bendingModel = BendingModel::Midedge; },
       {"symplectic_euler", "backward_euler", "bdf2"}, "bending.model"},
      {"dihedral bending", [](Scene& s) { s.bendingStiffness = 1e-6; s.bendingModel = BendingModel::Dihedral; },
       {"symplectic_euler", "backward_euler", "bdf2", "xpbd"}, "bending.model"},
      {"quadratic bending", [](Scene& s) { s.bendingStiffness = 1e-6; s.bendingModel = BendingModel::Quadratic; },
       {"symplectic_euler", "backward_euler", "bdf2", "xpbd", "projective_dynamics"}, ""},
      {"stiffness damping", [](Scene& s) { s.damping.stiffnessProportional = 1e-3; },
       {"symplectic_euler", "backward_euler", "bdf2", "xpbd"}, "damping.stiffness"},
      {"self-collision", [](Scene& s) { s.contact.selfCollision = true; },
       {"backward_euler", "bdf2"}, "contact.self_collision"},
  };
  for (const Feature& f : features) {
    for (const std::string& integrator : integratorNames()) {
      Scene s = gridScene(3, 4, 0.3, integrator);
      s.materialModel = "arap";
      f.ask(s);
      const Status status = validateScene(s);
      const bool accepted =
          std::find(f.accepting.begin(), f.accepting.end(), integrator) != f.accepting.end();
      EXPECT_EQ(status.ok(), accepted) << f.name << " with " << integrator << ": " << status.error();
      if (accepted || status.ok()) continue;
      // The key first, the integrator, and the integrators that would take it.
      EXPECT_EQ(status.error().rfind(f.key + ": integrator " + integrator + " does not support", 0), 0u)
          << status.error();
      std::string others;
      for (const std::string& n : f.accepting) others += (others.empty() ? "" : ", ") + n;
      EXPECT_TRUE(contains(status.error(), "or choose an integrator that does: " + others)) << status.error();
    }
  }
}

TEST(IntegratorRegistry, RefusalsSayWhatIsSupportedAndHowToComply) {
  Scene pd = gridScene(3, 4, 0.3, "projective_dynamics");
  pd.materialModel = "neo_hookean";
  EXPECT_EQ(checkIntegratorSupports(pd).error(),
            "material.model: integrator projective_dynamics does not support material "
            "'neo_hookean'; supported: arap (set material.model: arap, or choose an integrator "
            "that does: symplectic_euler, backward_euler, bdf2, xpbd)");
  pd.materialModel = "arap";
  pd.bendingStiffness = 1e-6;  // midedge, the default
  EXPECT_EQ(checkIntegratorSupports(pd).error(),
            "bending.model: integrator projective_dynamics does not support bending model "
            "'midedge' (the default); supported: quadratic (set bending.model: quadratic, or "
            "choose an integrator that does: symplectic_euler, backward_euler, bdf2)");
  Scene unknown = gridScene(3, 4, 0.3, "leapfrog");
  EXPECT_TRUE(contains(checkIntegratorSupports(unknown).error(), "integrator.name: unknown integrator"));
}

TEST(IntegratorRegistry, CapabilitiesTextNamesTheLimits) {
  EXPECT_EQ(capabilitiesText((*findIntegrator("projective_dynamics"))->supports),
            "materials: arap; bending: quadratic; 3D only; no obstacles; mass damping only");
  EXPECT_EQ(capabilitiesText((*findIntegrator("bdf2"))->supports),
            "materials: all; bending: all; 2D and 3D; obstacles (barriers), self-contact; assembles Hessians");
  EXPECT_EQ(capabilitiesText((*findIntegrator("symplectic_euler"))->supports),
            "materials: all; bending: all; 2D and 3D; obstacles (projection)");
}

}  // namespace
}  // namespace fem_cloth
