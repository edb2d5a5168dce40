// One term of the incremental potential (potential/incremental_potential.h), the single object
// implicit solvers minimise:
//
//   Phi(x) = 1/2 |x - xhat|_M^2 + c^2 sum_conservative E_t(x) + sum_dissipative Phi_t(x).
//
// A conservative term is an energy E(x) in joules: the membrane and bending of the Model, the
// IPC barrier and lagged friction of the contact, the work potential -f.x of constant loads. A
// dissipative term is a dissipation potential R(v) (W) at the step's velocity v = gamma (x - xc),
// which enters Phi as c^2 / gamma R(gamma (x - xc)): its x-gradient is then -c^2 times the
// dissipative force at v, so dPhi/dx = 0 is the implicit equation of motion (Gast, Schroeder,
// Stomakhin, Jiang & Teran, "Optimization Integrator for Large Time Steps", 2015, section 5).
// Rayleigh damping and the air are dissipative. A dissipative term reports its share of Phi
// directly (in J, scaled by the step's coefficients, see SubstepFrame).
//
// Pins are not terms: they are constraints the solver eliminates (their DOFs are fixed).
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <limits>
#include <string>
#include <vector>

#include "fem_cloth/core/energy_term.h"

namespace fem_cloth {

enum class TermRole {
  Conservative,  ///< a stored energy E(x) (J): Phi gains c^2 E
  Load,          ///< the work potential -f.x of forces constant over the step: Phi gains c^2 E
  Dissipative,   ///< a dissipation potential: reports its share of Phi itself
};

/// What a term offers; solvers check these before they rely on a feature.
struct TermCapabilities {
  bool hessian = true;         ///< fills Hessians (Newton needs them)
  bool stepBound = false;      ///< prepareStep() bounds steps (continuous collision detection)
  bool perVertex = false;      ///< vertexDerivatives() is available (local solvers)
  bool outsidePattern = false;  ///< its Hessian may couple vertices the Model's pattern does not
};

/// The substep Phi is built for: positions at its start, the scheme's coefficients and the
/// constraints. Velocities are v = gamma (x - xc).
struct SubstepFrame {
  const VectorX* x0 = nullptr;  ///< positions at the start of the substep (m)
  const VectorX* xc = nullptr;  ///< the velocity's origin (m): x0 for backward Euler
  double h = 0.0;               ///< substep length (s)
  double c2 = 0.0;              ///< weight of the conservative terms (s^2)
  double gamma = 0.0;           ///< v = gamma (x - xc) (1/s)
  const std::vector<char>* pinned = nullptr;  ///< per DOF: 1 if pinned (eliminated)
  int dim = 3;                                ///< of the mesh: 2 (planar) or 3
  double fractionStart = 0.0, fractionEnd = 1.0;  ///< the substep's share of the step
};

/// What one evaluation asks of a term. Conservative and load terms add dE/dx to `gradient`
/// and hessianScale x d^2E/dx^2 to `hessian` (entries outside its pattern to `outside`);
/// dissipative terms add their share's x-derivatives (hessianScale is 1 for them).
struct TermRequest {
  bool energy = true;
  VectorX* gradient = nullptr;
  SparseHessian* hessian = nullptr;
  std::vector<Eigen::Triplet<double>>* outside = nullptr;
  double hessianScale = 1.0;
  HessianMode hessianMode = HessianMode::Projected;
  /// For a term that continuesSum(): the running energy sum it continues (J).
  double energyStart = 0.0;
};

class PotentialTerm {
 public:
  virtual ~PotentialTerm() = default;
  virtual std::string name() const = 0;
  virtual TermRole role() const = 0;
  virtual TermCapabilities capabilities() const = 0;
  /// Before any evaluation in a substep: lagged quantities are taken at frame.x0 here.
  virtual void beginSubstep(const SubstepFrame& /*frame*/) {}
  /// Energy (or share of Phi) at x; derivatives on request. Outside the term's domain the
  /// energy is +inf and inDomain false.
  virtual EvalResult evaluate(const VectorX& x, const TermRequest& request) = 0;
  /// Readies the term for evaluations along x + t dx, t in [0, 1] (dx may be zero), and
  /// returns the largest t it finds safe; +inf for a term without a step bound. With perDof,
  /// lowers each DOF's entry to the t at which a constraint it takes part in would stop the
  /// step (StepBound::perDof, solvers/line_search.h).
  virtual double prepareStep(const VectorX& /*x*/, const VectorX& /*dx*/, VectorX* /*perDof*/) {
    return std::numeric_limits<double>::infinity();
  }
  /// True for a term whose energy continues the previous term's running sum: the potential
  /// passes that sum as request.energyStart, and the term returns the sum with its own energy
  /// added element by element. Two terms split from one (the contact's barriers and friction)
  /// then sum exactly as the one did.
  virtual bool continuesSum() const { return false; }
  /// k with the term's x-Hessian k M (M the lumped mass): the potential adds it to the inertia's
  /// diagonal, and evaluate() adds no Hessian of its own. 0 for other terms.
  virtual double massProportionalHessian() const { return 0.0; }
  /// Per-vertex access (capabilities().perVertex; VertexDerivatives in energy_term.h): the
  /// term's force and 3 x 3 Hessian block at one vertex, in the units of its share of Phi (for
  /// conservative and load terms, of E: the potential weights them by c^2). mode as for
  /// EnergyTerm::vertexDerivatives. False when the term does not offer it, is not prepared, or
  /// an element around the vertex is outside its domain.
  ///
  /// The contract is EnergyTerm's: prepareVertexAccess() once after construction (for a term
  /// whose elements change, such as contact pairs, after every change) before vertexDerivatives,
  /// which until then returns false without touching `out`; after it, vertexDerivatives is
  /// const and thread-safe. Nothing to prepare by default (the loads, the damping).
  virtual void prepareVertexAccess() {}
  virtual bool vertexDerivatives(const VectorX& /*x*/, Index /*vertex*/, HessianMode /*mode*/,
                                 VertexDerivatives& /*out*/) const {
    return false;
  }
};

}  // namespace fem_cloth
