// The terms of the implicit steppers' incremental potential (potential_term.h).
#pragma once

#include <vector>

#include "fem_cloth/core/integrators/integrator.h"
#include "fem_cloth/core/potential/potential_term.h"

namespace fem_cloth {

class AirModel;
class ContactModel;

/// The Model's energy terms (membrane, bending): E(x) their sum. The Model owns the Hessian
/// pattern every other term adds into.
class ElasticTerm final : public PotentialTerm {
 public:
  void bind(Model& model) { model_ = &model; }
  std::string name() const override { return "elastic"; }
  TermRole role() const override { return TermRole::Conservative; }
  /// Per-vertex when every term of the Model offers it (Model::hasVertexDerivatives).
  TermCapabilities capabilities() const override;
  EvalResult evaluate(const VectorX& x, const TermRequest& request) override;
  /// Model::prepareVertexAccess.
  void prepareVertexAccess() override;
  bool vertexDerivatives(const VectorX& x, Index vertex, HessianMode mode,
                         VertexDerivatives& out) const override;

 private:
  Model* model_ = nullptr;
};

/// Gravity and the commanded forces, f constant over the step: E(x) = -f.x.
class LoadTerm final : public PotentialTerm {
 public:
  /// f = gravity + external (per DOF, N).
  void setForces(const VectorX& gravity, const VectorX& external) { force_ = gravity + external; }
  const VectorX& force() const { return force_; }
  std::string name() const override { return "loads"; }
  TermRole role() const override { return TermRole::Load; }
  TermCapabilities capabilities() const override { return {true, false, true, false}; }
  void beginSubstep(const SubstepFrame& frame) override { dim_ = frame.dim; }
  EvalResult evaluate(const VectorX& x, const TermRequest& request) override;
  bool vertexDerivatives(const VectorX& x, Index vertex, HessianMode mode,
                         VertexDerivatives& out) const override;

 private:
  VectorX force_;
  int dim_ = 3;
};

/// Mass-proportional Rayleigh damping, force -alpha M v: R(v) = alpha/2 v^T M v, so its share of
/// Phi is c^2 gamma alpha/2 |x - xc|_M^2, with the Hessian c^2 gamma alpha M.
class MassDampingTerm final : public PotentialTerm {
 public:
  MassDampingTerm() = default;
  void configure(double alpha, const VectorX& mass) {
    alpha_ = alpha;
    mass_ = &mass;
  }
  std::string name() const override { return "mass damping"; }
  TermRole role() const override { return TermRole::Dissipative; }
  TermCapabilities capabilities() const override { return {true, false, true, false}; }
  void beginSubstep(const SubstepFrame& frame) override { frame_ = frame; }
  EvalResult evaluate(const VectorX& x, const TermRequest& request) override;
  double massProportionalHessian() const override { return frame_.c2 * frame_.gamma * alpha_; }
  bool vertexDerivatives(const VectorX& x, Index vertex, HessianMode mode,
                         VertexDerivatives& out) const override;
  /// The energy it removes over a substep of length h ending at velocity v: h alpha v^T M v.
  double dissipated(const VectorX& v, double h) const;

 private:
  double alpha_ = 0.0;
  const VectorX* mass_ = nullptr;
  SubstepFrame frame_;
};

/// Stiffness-proportional Rayleigh damping, force -beta K0 v with K0 the PSD-projected stiffness
/// of the Model at the start of the substep (lagged, so the term stays quadratic and convex):
/// R(v) = 1/2 v^T beta K0 v, its share of Phi c^2 gamma/2 (x - xc)^T beta K0 (x - xc).
class StiffnessDampingTerm final : public PotentialTerm {
 public:
  void configure(double beta, Model& model) {
    beta_ = beta;
    model_ = &model;
  }
  std::string name() const override { return "stiffness damping"; }
  TermRole role() const override { return TermRole::Dissipative; }
  TermCapabilities capabilities() const override { return {true, false, true, false}; }
  /// Assembles beta K0 at frame.x0 (in the Model's Hessian pattern).
  void beginSubstep(const SubstepFrame& frame) override;
  EvalResult evaluate(const VectorX& x, const TermRequest& request) override;
  bool vertexDerivatives(const VectorX& x, Index vertex, HessianMode mode,
                         VertexDerivatives& out) const override;
  /// h v^T beta K0 v.
  double dissipated(const VectorX& v, double h);

 private:
  /// y = beta K0 z.
  void product(const VectorX& z, VectorX& y) const;
  double beta_ = 0.0;
  Model* model_ = nullptr;
  SubstepFrame frame_;
  std::vector<double> values_;  // beta K0 in the Model's pattern
  VectorX scratch_;
};

/// The air (air.h): its dissipation potential D at the step's velocity, share c^2 / gamma D,
/// normals and areas lagged at the start of the substep.
class AirTerm final : public PotentialTerm {
 public:
  void bind(AirModel& air) { air_ = &air; }
  std::string name() const override { return "air"; }
  TermRole role() const override { return TermRole::Dissipative; }
  TermCapabilities capabilities() const override { return {true, false, true, false}; }
  void beginSubstep(const SubstepFrame& frame) override;
  EvalResult evaluate(const VectorX& x, const TermRequest& request) override;
  /// AirModel::prepareVertexAccess.
  void prepareVertexAccess() override;
  /// The air's share at one vertex: force c^2 f_v at v = gamma (x - xc) of its triangles,
  /// block c^2 gamma d^2D/dv_v^2 (PSD in both modes).
  bool vertexDerivatives(const VectorX& x, Index vertex, HessianMode mode,
                         VertexDerivatives& out) const override;
  /// The air force at velocity v (N per DOF).
  const VectorX& force(const VectorX& v);

 private:
  AirModel* air_ = nullptr;
  SubstepFrame frame_;
  VectorX velocity_, force_;
};

/// Incremental Potential Contact (Li et al. 2020; contact/contact_model.h), the barriers:
/// kappa B(x) over the vertex-obstacle pairs and, with self-collision, the point-triangle and
/// edge-edge pairs closer than dHat; each step bounded by continuous collision detection. It
/// starts the contact's substep (obstacle poses, the lagged friction's contacts), so it is added
/// before FrictionTerm.
class BarrierTerm final : public PotentialTerm {
 public:
  void bind(ContactModel& contact) { contact_ = &contact; }
  std::string name() const override { return "contact barriers"; }
  TermRole role() const override { return TermRole::Conservative; }
  TermCapabilities capabilities() const override { return {true, true, true, true}; }
  void beginSubstep(const SubstepFrame& frame) override;
  EvalResult evaluate(const VectorX& x, const TermRequest& request) override;
  double prepareStep(const VectorX& x, const VectorX& dx, VectorX* perDof) override;
  /// ContactModel::vertexDerivatives' barriers: the block of the assembled (PSD, Gauss-Newton)
  /// Hessian in both modes, from the pairs of the last prepareStep() (prepare after each).
  void prepareVertexAccess() override;
  bool vertexDerivatives(const VectorX& x, Index vertex, HessianMode mode,
                         VertexDerivatives& out) const override;

 private:
  ContactModel* contact_ = nullptr;
};

/// The lagged friction of the contacts (Li et al. 2020, section 5): D(x) over the contacts of
/// the start of the substep, with their normal forces and tangent planes fixed. Its energy is
/// summed onto the barriers' (continuesSum), as the contact's was when the two were one term.
class FrictionTerm final : public PotentialTerm {
 public:
  void bind(ContactModel& contact) { contact_ = &contact; }
  std::string name() const override { return "contact friction"; }
  TermRole role() const override { return TermRole::Conservative; }
  TermCapabilities capabilities() const override { return {true, false, true, true}; }
  bool continuesSum() const override { return true; }
  EvalResult evaluate(const VectorX& x, const TermRequest& request) override;
  /// ContactModel::vertexDerivatives' friction (its exact Hessian block, PSD); prepare after
  /// each beginSubstep.
  void prepareVertexAccess() override;
  bool vertexDerivatives(const VectorX& x, Index vertex, HessianMode mode,
                         VertexDerivatives& out) const override;

 private:
  ContactModel* contact_ = nullptr;
};

}  // namespace fem_cloth
