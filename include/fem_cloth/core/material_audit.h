// The material audit: measures, on fixed deterministic samples, the properties a membrane energy
// needs before the simulator may use it, for the six models and for two plausible-looking energies
// that must be rejected. Each criterion gives a measured number and a pass/fail; a model is
// accepted when it passes every criterion that decides.
//
// Criteria (planar elements with T = I and cloth elements with several orthonormal rest frames T;
// k = mu + |lambda| is the stiffness scale the tolerances are relative to):
//   rest energy        max |psi(T)|                                         decides
//   rest stress        max |P(T)| (largest entry)                           decides
//   non-negative       min psi over wide samples inside the domain          decides
//   rotation invariant max |psi(Q F) - psi(F)| over samples and rotations   decides, except for a
//                      model that declares kRotationInvariant = false (linear elasticity, the
//                      small-strain reference): measured and reported, exempt
//   linear order       p in |psi - psi_linear| ~ eps^p at F = T (I + eps H), psi_linear the
//                      small-strain energy with the model's own mu and lambda (0 for ARAP); p = 3
//                      means agreement to second order (pass: p >= 2.5); "exact" (p = infinity)
//                      for linear elasticity itself                         decides
//   stress vs FD       max |P - central differences of psi| / max(|P|, k)  decides
//   Hessian PSD        min eigenvalue of the projected stress Hessian / max(|H|, k)   decides
//   collapse finite    psi at F = diag(1, 0)                                reported
//   collapse restoring -P22 at F = diag(1, 0): the force on s along F = diag(1, s); > 0 pushes the
//                      element back towards rest                            reported
//   inversion finite / inversion restoring: the same at F = diag(1, -0.5)  reported
// What happens at collapse and inversion does not make an energy invalid; it decides which scenes
// and integrators suit it (StVK softens and inverts under strong compression, Neo-Hookean is a
// barrier that needs a line search keeping J > 0), so it is reported and does not decide.
// References: Sifakis & Barbic 2012, sections 3.2-3.4; Kim & Eberle 2022, sections 3-5; Smith,
// De Goes & Kim 2018 (Stable Neo-Hookean), section 3.
#pragma once

#include <string>
#include <vector>

#include "fem_cloth/core/materials/materials.h"

namespace fem_cloth {

/// psi = mu (||F||^2 - offset), a counterexample for the audit, kept out of the Material variant:
/// with offset 0 it is not zero at rest (psi(I) = 2 mu, P(I) = 2 mu I: it pulls every element to
/// a point); with offset 2 it is zero at rest but not stationary there, so it goes negative under
/// compression. Both are rotation invariant, with exact derivatives and a constant PSD Hessian
/// 2 mu I, so that the audit rejects them for those reasons only.
class SquaredNormEnergy : public MaterialBase {
 public:
  static constexpr bool kRotationInvariant = true;

  SquaredNormEnergy(double mu, double offset) : MaterialBase(Lame{mu, 0.0}), offset_(offset) {}

  template <int D>
  double psi(const DefGrad<D>& F, const DefGrad<D>& /*T*/) const {
    return mu_ * (F.squaredNorm() - offset_);
  }
  template <int D>
  DefGrad<D> pk1(const DefGrad<D>& F, const DefGrad<D>& /*T*/) const {
    return 2.0 * mu_ * F;
  }
  template <int D>
  StressHessian<D> hessian(const DefGrad<D>& /*F*/, const DefGrad<D>& /*T*/) const {
    return 2.0 * mu_ * StressHessian<D>::Identity();
  }
  template <int D>
  StressHessian<D> projectedHessian(const DefGrad<D>& F, const DefGrad<D>& T) const {
    return hessian<D>(F, T);
  }

 private:
  double offset_;
};

/// The names the audit gives the two counterexamples.
constexpr const char* kSquaredNormName = "norm_squared";
constexpr const char* kShiftedSquaredNormName = "norm_squared_minus_2";

/// Criterion names, in the order every MaterialAudit lists them.
namespace audit_criterion {
constexpr const char* kRestEnergy = "rest energy";
constexpr const char* kRestStress = "rest stress";
constexpr const char* kNonNegative = "non-negative";
constexpr const char* kRotationInvariant = "rotation invariant";
constexpr const char* kLinearOrder = "linear order";
constexpr const char* kStressMatchesFd = "stress vs FD";
constexpr const char* kHessianPsd = "Hessian PSD";
constexpr const char* kCollapseFinite = "collapse finite";
constexpr const char* kCollapseRestoring = "collapse restoring";
constexpr const char* kInversionFinite = "inversion finite";
constexpr const char* kInversionRestoring = "inversion restoring";
}  // namespace audit_criterion

struct AuditCriterion {
  std::string name;
  /// The measured number (see the table above); NaN when it cannot be measured (the point is
  /// outside the model's domain), +infinity for an exact agreement or an infinite energy.
  double measured = 0.0;
  bool pass = false;
  /// Whether the criterion counts for the verdict.
  bool decides = true;
  /// Why a criterion does not decide or was not measured, e.g. "exempt: small-strain reference".
  std::string note;
};

struct MaterialAudit {
  std::string model;
  bool counterexample = false;
  std::vector<AuditCriterion> criteria;
  bool accepted = false;
  /// "accepted", or "rejected: " and the failed deciding criteria.
  std::string verdict;

  /// The criterion of that name; throws std::out_of_range for an unknown name.
  const AuditCriterion& criterion(const std::string& name) const;
};

/// Audits the six models (in materialNames() order) and then the two counterexamples, all built
/// with these Lame parameters (N/m). Deterministic: the samples come from a fixed seed.
std::vector<MaterialAudit> auditMaterials(const Lame& lame);

}  // namespace fem_cloth
