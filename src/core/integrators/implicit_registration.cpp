// The registry entries (registry.h) of the two implicit steppers: backward Euler and BDF2 share
// the solvers (Newton, L-BFGS: integrator.solver) and so their keys.
#include "fem_cloth/core/integrators/implicit.h"
#include "fem_cloth/core/integrators/registry.h"
#include "fem_cloth/core/scene.h"

namespace fem_cloth {

namespace {

// The solver keys (solver, lbfgs_memory, lbfgs_max_iterations), kept in the scene's integrator
// options under the integrator's name.
Status readSolver(const SettingsReader& r, ImplicitSolverSettings& settings) {
  std::string solver = implicitSolverName(settings.kind);
  FEM_CLOTH_CHECK(r.text("solver", solver));
  Expected<ImplicitSolver> kind = parseImplicitSolver(solver);
  if (!kind) return Error{r.where("solver") + ": " + kind.error()};
  settings.kind = *kind;
  FEM_CLOTH_CHECK(r.integer("lbfgs_memory", settings.lbfgs.memory));
  return r.integer("lbfgs_max_iterations", settings.lbfgs.maxIterations);
}

Status checkSolver(const ImplicitSolverSettings& settings) {
  FEM_CLOTH_CHECK(countInRange(settings.lbfgs.memory, 1, 100, "integrator.lbfgs_memory"));
  return countInRange(settings.lbfgs.maxIterations, 1, 100'000, "integrator.lbfgs_max_iterations");
}

IntegratorEntry implicitEntry(ImplicitScheme scheme) {
  IntegratorEntry e;
  e.name = scheme == ImplicitScheme::Bdf2 ? "bdf2" : "backward_euler";
  e.summary = scheme == ImplicitScheme::Bdf2
                  ? "second-order implicit (BDF2) by Newton on the incremental potential"
                  : "first-order implicit by Newton on the incremental potential (Gast et al. 2015)";
  // The IPC barrier (obstacles and self-contact) is a term of the potential Newton minimises.
  e.supports.contact = ContactMethod::Barriers;
  e.supports.selfContact = true;
  e.supports.needsHessian = true;
  e.keys = {"max_newton_iterations", "newton_tolerance", "max_backtracks", "linear_solver",
            "cg_tolerance", "cg_max_iterations", "solver", "lbfgs_memory", "lbfgs_max_iterations"};
  e.keys.insert(e.keys.end(), displacementErrorKeys().begin(), displacementErrorKeys().end());
  e.read = [name = e.name](const SettingsReader& r, Scene& s) -> Status {
    FEM_CLOTH_CHECK(readSolver(r, s.integratorOptions.edit<ImplicitSolverSettings>(name)));
    FEM_CLOTH_CHECK(readDisplacementTolerance(r, s));
    FEM_CLOTH_CHECK(r.integer("max_newton_iterations", s.newton.maxIterations));
    FEM_CLOTH_CHECK(r.number("newton_tolerance", s.newton.tolerance));
    FEM_CLOTH_CHECK(r.integer("max_backtracks", s.newton.maxBacktracks));
    std::string solver = linearSolverName(s.newton.linear.kind);
    FEM_CLOTH_CHECK(r.text("linear_solver", solver));
    Expected<LinearSolverKind> kind = parseLinearSolverKind(solver);
    if (!kind) return Error{r.where("linear_solver") + ": " + kind.error()};
    s.newton.linear.kind = *kind;
    FEM_CLOTH_CHECK(r.number("cg_tolerance", s.newton.linear.cgTolerance));
    return r.integer("cg_max_iterations", s.newton.linear.cgMaxIterations);
  };
  e.check = [name = e.name](const Scene& s) -> Status {
    FEM_CLOTH_CHECK(checkSolver(s.integratorOptions.get<ImplicitSolverSettings>(name)));
    FEM_CLOTH_CHECK(checkDisplacementTolerance(s));
    FEM_CLOTH_CHECK(countInRange(s.newton.maxIterations, 1, 10'000, "integrator.max_newton_iterations"));
    FEM_CLOTH_CHECK(inRange(s.newton.tolerance, 1e-12, 10.0, "integrator.newton_tolerance", "1/s"));
    FEM_CLOTH_CHECK(countInRange(s.newton.maxBacktracks, 0, 200, "integrator.max_backtracks"));
    FEM_CLOTH_CHECK(inRange(s.newton.linear.cgTolerance, 1e-16, 0.1, "integrator.cg_tolerance", ""));
    return countInRange(s.newton.linear.cgMaxIterations, 1, 10'000'000, "integrator.cg_max_iterations");
  };
  e.make = [scheme, name = e.name](const Scene& s) -> std::unique_ptr<Integrator> {
    return std::make_unique<ImplicitIntegrator>(scheme, s.newton,
                                                s.integratorOptions.get<ImplicitSolverSettings>(name));
  };
  return e;
}

}  // namespace

IntegratorEntry backwardEulerEntry() { return implicitEntry(ImplicitScheme::BackwardEuler); }
IntegratorEntry bdf2Entry() { return implicitEntry(ImplicitScheme::Bdf2); }

}  // namespace fem_cloth
