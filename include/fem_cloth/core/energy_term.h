// The interface every energy term of a model implements (membrane, bending; later contact).
// A term fills the gradient and the Hessian only when asked (null pointer = not needed), in the
// sign convention of conventions.h: gradient = +dE/dx.
#pragma once

#include <Eigen/SparseCore>
#include <limits>
#include <string>
#include <vector>

#include "fem_cloth/core/conventions.h"
#include "fem_cloth/core/mesh.h"
#include "fem_cloth/core/sparse_hessian.h"

namespace fem_cloth {

class ConstraintForm;
class ProjectiveForm;

enum class HessianMode {
  Exact,      ///< d^2E/dx^2 as it is (may be indefinite)
  Projected,  ///< each element's Hessian projected to positive semi-definite (for Newton)
};

constexpr double kInfiniteEnergy = std::numeric_limits<double>::infinity();

/// Element loops run in parallel (OpenMP) only from this many elements on: below it, waking the
/// thread team costs more than the work, and on a busy machine libgomp's spinning threads make
/// small parallel loops many times slower than serial ones.
constexpr int kParallelElementThreshold = 4096;

struct EvalRequest {
  bool energy = true;              ///< compute the energy (else the result's energy is 0)
  VectorX* gradient = nullptr;     ///< if set, += dE/dx
  SparseHessian* hessian = nullptr;  ///< if set, += d^2E/dx^2 into its fixed pattern
  HessianMode hessianMode = HessianMode::Projected;
};

struct EvalResult {
  double energy = 0.0;       ///< joules
  bool inDomain = true;      ///< false: some element is outside its model's domain (energy = inf)
  Index firstBadElement = -1;  ///< the first such element
};

/// Acceptance test (c) (integrators/acceptance.h): how far a term's worst element is from the
/// validity range of its model.
struct Validity {
  double measure = 0.0;  ///< the model's validity measure at the worst element
  double limit = std::numeric_limits<double>::infinity();  ///< its largest valid value
  Index element = -1;    ///< the worst element (-1: none measured)
  const char* what = "";  ///< what the measure is, for messages
  const char* advice = "";  ///< what to do about it, for messages
  bool ok() const { return !(measure > limit); }
};

/// The derivatives of a term with respect to one vertex's position, with the other vertices
/// held fixed: the force -dE/dx_v (N; for a dissipative term of the incremental potential,
/// -dPhi_t/dx_v) and the 3 x 3 block d^2E/dx_v^2 (N/m; on a planar mesh only the top-left 2 x 2
/// is used, the rest is zero). Vertex block descent (Chen, Macklin et al., "Vertex Block
/// Descent", 2024) minimises one vertex at a time with these.
struct VertexDerivatives {
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  Eigen::Matrix3d hessian = Eigen::Matrix3d::Zero();
};

class EnergyTerm {
 public:
  virtual ~EnergyTerm() = default;
  virtual std::string name() const = 0;
  /// Vertex sets whose DOFs the term couples; they define the Hessian pattern.
  virtual void appendStencils(std::vector<std::vector<Index>>* stencils) const = 0;
  /// Called once when the model builds its Hessian pattern, to cache value offsets.
  virtual void bindHessian(const SparseHessian& hessian) = 0;
  /// Evaluates at the flat positions x. Outside the domain, gradient and Hessian are left
  /// untouched for the offending elements and inDomain is false.
  virtual EvalResult evaluate(const VectorX& x, const EvalRequest& request) = 0;
  /// True if the Hessian does not depend on x (quadratic terms).
  virtual bool hasConstantHessian() const { return false; }

  /// True if the term's model is valid only in part of its domain (the linear membrane); only
  /// then is validity() evaluated.
  virtual bool hasValidityRange() const { return false; }
  /// The element with the largest validity measure at x (see Validity).
  virtual Validity validity(const VectorX& /*x*/) const { return {}; }

  /// Per-vertex access, for local solvers: the force and Hessian block at `vertex` of the
  /// elements whose stencil holds it, summed. Exact: the block of the exact Hessian; Projected:
  /// each element's Hessian made PSD first, as evaluate() projects it, so the block is PSD. The
  /// elements around one vertex only are evaluated (cost independent of the mesh size), and the
  /// call is thread-safe once prepared (no member is written). False when the term does not
  /// offer it (hasVertexDerivatives), is not prepared, or an element around the vertex is
  /// outside its domain.
  ///
  /// The contract: a term offering it needs prepareVertexAccess() once after construction, and,
  /// a term whose elements change (contact pairs), after every change, before vertexDerivatives.
  /// Until then vertexDerivatives returns false without touching `out`. Construction builds none
  /// of it (the vertex-to-element table), so a scene whose solver never asks does not pay for it.
  virtual bool hasVertexDerivatives() const { return false; }
  /// Builds what vertexDerivatives reads (a VertexIncidence table); not thread-safe, cheap when
  /// nothing changed since the last call. Nothing to prepare by default.
  virtual void prepareVertexAccess() {}
  virtual bool vertexDerivatives(const VectorX& /*x*/, Index /*vertex*/, HessianMode /*mode*/,
                                 VertexDerivatives& /*out*/) const {
    return false;
  }

  /// Optional forms for solvers other than Newton's (energy_forms.h): the constraint form
  /// XPBD visits element by element, the projective form Projective Dynamics minimises. Null
  /// when the term has none.
  virtual const ConstraintForm* constraintForm() const { return nullptr; }
  virtual ProjectiveForm* projectiveForm() { return nullptr; }
};

/// The vertex-to-element table of a term's stencils (appendStencils: element e is stencil e).
inline VertexIncidence stencilIncidence(const EnergyTerm& term, Index numVertices) {
  std::vector<std::vector<Index>> stencils;
  term.appendStencils(&stencils);
  return VertexIncidence(numVertices, stencils);
}

}  // namespace fem_cloth
