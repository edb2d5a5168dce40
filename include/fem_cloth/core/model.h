// A discretised cloth: the mesh, its rest state, lumped masses and the energy terms a scene
// declares (membrane, and bending when its stiffness is non-zero). A term that is not declared is
// never evaluated. The Hessian pattern is built only when an integrator asks for it.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "fem_cloth/core/energy_term.h"
#include "fem_cloth/core/mesh.h"
#include "fem_cloth/core/rest_state.h"
#include "fem_cloth/core/sparse_hessian.h"

namespace fem_cloth {

/// What a term counts as in the energy report.
enum class TermKind { Membrane, Bending, Other };

class Model {
 public:
  Model(std::shared_ptr<const Mesh> mesh, std::shared_ptr<const RestState> rest,
        VectorX vertexMasses);

  void addTerm(std::unique_ptr<EnergyTerm> term, TermKind kind);

  const Mesh& mesh() const { return *mesh_; }
  std::shared_ptr<const Mesh> sharedMesh() const { return mesh_; }
  const RestState& rest() const { return *rest_; }
  std::shared_ptr<const RestState> sharedRest() const { return rest_; }
  int dim() const { return mesh_->dim; }
  Index numVertices() const { return mesh_->numVertices(); }
  Index numDofs() const { return mesh_->numDofs(); }
  /// Lumped mass per vertex (kg).
  const VectorX& vertexMasses() const { return vertexMasses_; }
  /// Lumped mass per DOF (kg): vertexMasses repeated dim times.
  const VectorX& dofMasses() const { return dofMasses_; }
  double totalMass() const { return vertexMasses_.sum(); }

  std::size_t numTerms() const { return terms_.size(); }
  EnergyTerm& term(std::size_t i) { return *terms_[i].term; }
  const EnergyTerm& term(std::size_t i) const { return *terms_[i].term; }
  TermKind termKind(std::size_t i) const { return terms_[i].kind; }

  /// Sum over all terms. With request.hessian set, the pattern must come from hessianPattern().
  EvalResult evaluate(const VectorX& x, const EvalRequest& request);

  /// Per-vertex access (EnergyTerm::vertexDerivatives) summed over the terms: offered when every
  /// term offers it; false, out untouched, when one does not, is not prepared, or is outside its
  /// domain around the vertex. prepareVertexAccess() prepares every term (EnergyTerm's contract).
  bool hasVertexDerivatives() const;
  void prepareVertexAccess();
  bool vertexDerivatives(const VectorX& x, Index vertex, HessianMode mode,
                         VertexDerivatives& out) const;

  /// Elastic energy split by kind (J); +inf in a kind whose term is outside its domain.
  struct Energies {
    double membrane = 0.0;
    double bending = 0.0;
    double other = 0.0;
    double total() const { return membrane + bending + other; }
  };
  Energies energies(const VectorX& x);

  /// Acceptance test (c): the first term whose worst element is outside its model's validity
  /// range at x, or (all valid) the term closest to its limit; only terms with a range are
  /// evaluated, so a model without one costs nothing.
  struct TermValidity {
    Validity validity;
    int term = -1;  ///< the term's index (-1 when no term has a range)
  };
  bool hasValidityRanges() const { return hasValidityRanges_; }
  TermValidity validity(const VectorX& x) const;

  /// The Hessian with the pattern of all terms (built on first use, then reused: the pattern
  /// depends on the topology only). Every term is bound to it.
  SparseHessian& hessianPattern();
  bool hasHessianPattern() const { return hessian_ != nullptr; }

 private:
  struct Entry {
    std::unique_ptr<EnergyTerm> term;
    TermKind kind;
  };
  std::shared_ptr<const Mesh> mesh_;
  std::shared_ptr<const RestState> rest_;
  VectorX vertexMasses_;
  VectorX dofMasses_;
  std::vector<Entry> terms_;
  std::unique_ptr<SparseHessian> hessian_;
  bool hasValidityRanges_ = false;
};

}  // namespace fem_cloth
