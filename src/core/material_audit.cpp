#include "fem_cloth/core/material_audit.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

namespace fem_cloth {

namespace {

namespace criterion = audit_criterion;

constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr double kNotMeasured = std::numeric_limits<double>::quiet_NaN();

// Tolerances, relative to the stiffness scale k = mu + |lambda| (N/m). The samples are of order
// one (|F| <= about 3), so psi and P are at most a few tens of k and double round-off stays below
// 1e-13 k.
constexpr double kRestTolerance = 1e-12;
constexpr double kNegativeTolerance = 1e-10;
constexpr double kInvarianceTolerance = 1e-10;
constexpr double kRestoringTolerance = 1e-12;
// |psi - psi_linear| below this (relative to k) at both eps counts as exact agreement.
constexpr double kExactAgreement = 1e-14;
// Agreement to second order gives p = 3, to first order only p = 2.
constexpr double kMinimumLinearOrder = 2.5;
// Central differences with step h have error h^2 |P'''| + eps_machine |psi| / h: about 1e-10 for
// h = 1e-6 away from singularities.
constexpr double kFdStep = 1e-6;
constexpr double kFdTolerance = 1e-6;
constexpr double kPsdTolerance = 1e-10;

/// Uniform numbers from std::mt19937, whose sequence the C++ standard fixes. The mapping to
/// [lo, hi] is written here (std::uniform_real_distribution is implementation-defined), so the
/// samples, and with them the measured numbers, are the same with every compiler.
class SampleSource {
 public:
  explicit SampleSource(unsigned seed) : rng_(seed) {}
  double uniform(double lo, double hi) {
    return lo + (hi - lo) * (static_cast<double>(rng_()) / 4294967296.0);
  }
  template <int Rows, int Cols>
  Eigen::Matrix<double, Rows, Cols> matrix(double lo, double hi) {
    Eigen::Matrix<double, Rows, Cols> m;
    for (int i = 0; i < Rows * Cols; ++i) m.data()[i] = uniform(lo, hi);
    return m;
  }
  /// A rotation of R^D by an angle in (-pi, pi) (about a random axis in 3D).
  template <int D>
  Eigen::Matrix<double, D, D> rotation() {
    const double angle = uniform(-M_PI, M_PI);
    if constexpr (D == 2) {
      return Eigen::Rotation2Dd(angle).toRotationMatrix();
    } else {
      Eigen::Vector3d axis = matrix<3, 1>(-1.0, 1.0);
      while (axis.norm() < 0.1) axis = matrix<3, 1>(-1.0, 1.0);
      return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
    }
  }

 private:
  std::mt19937 rng_;
};

template <int D>
struct Sample {
  DefGrad<D> F;
  DefGrad<D> T;
};

/// A direction of deformation away from rest: F = T (I + eps H) + eps n b^T (b = 0 for planar).
struct Direction {
  Eigen::Matrix2d H;
  Eigen::Matrix<double, 1, 2> b;
};

Eigen::Matrix2d diag(double a, double b) { return Eigen::Vector2d(a, b).asDiagonal(); }

/// The fixed samples for planar (D = 2) or cloth (D = 3) elements.
template <int D>
struct SampleSet {
  std::vector<DefGrad<D>> restFrames;
  /// Stretched, compressed, sheared and (planar) inverted deformations, |entries| <= 2.
  std::vector<Sample<D>> wide;
  /// Around rest, T (I + 0.5 A) (+ out of plane for cloth), away from collapse.
  std::vector<Sample<D>> moderate;
  /// s1 = s2, s1 - s2 tiny, near collapse, and (planar) inverted.
  std::vector<Sample<D>> hard;
  std::vector<Eigen::Matrix<double, D, D>> rotations;
  std::vector<Direction> directions;
};

template <int D>
DefGrad<D> unitNormalTimes(const DefGrad<D>& T, const Eigen::Matrix<double, 1, 2>& b) {
  if constexpr (D == 3) {
    return T.col(0).cross(T.col(1)) * b;
  } else {
    return DefGrad<D>::Zero();
  }
}

template <int D>
SampleSet<D> makeSamples() {
  SampleSource source(20240601 + D);
  SampleSet<D> set;
  if constexpr (D == 2) {
    set.restFrames = {DefGrad<2>::Identity()};
  } else {
    DefGrad<3> flat = DefGrad<3>::Zero();
    flat(0, 0) = flat(1, 1) = 1.0;
    set.restFrames.push_back(flat);
    set.restFrames.push_back(source.rotation<3>() * flat);
    set.restFrames.push_back(source.rotation<3>() * flat);
  }
  const Eigen::Matrix2d shear = Eigen::Rotation2Dd(0.4).toRotationMatrix();
  // Inversions for planar elements only: a cloth triangle has no orientation. Collapsed samples
  // other than F = 0 are left out: J there is zero up to round-off, and the sign of that
  // round-off would decide whether a barrier model is inside its domain.
  const std::vector<double> stretches =
      D == 2 ? std::vector<double>{-0.5, 0.25, 0.5, 1.0, 1.5, 2.0}
             : std::vector<double>{0.25, 0.5, 1.0, 1.5, 2.0};
  for (const DefGrad<D>& T : set.restFrames) {
    set.wide.push_back({DefGrad<D>::Zero(), T});
    for (int k = 0; k < 60; ++k) set.wide.push_back({source.matrix<D, 2>(-1.5, 1.5), T});
    for (double a : stretches) {
      for (double b : stretches) set.wide.push_back({T * shear * diag(a, b) * shear, T});
    }
    for (int k = 0; k < 20; ++k) {
      const Eigen::Matrix2d A = source.matrix<2, 2>(-1.0, 1.0);
      const DefGrad<D> F = T * (Eigen::Matrix2d::Identity() + 0.5 * A) +
                           0.3 * unitNormalTimes<D>(T, source.matrix<1, 2>(-1.0, 1.0));
      const Eigen::Matrix2d C = F.transpose() * F;
      if (std::sqrt(std::abs(C.determinant())) >= 0.2) set.moderate.push_back({F, T});
    }
    const Eigen::Matrix2d R = Eigen::Rotation2Dd(0.7).toRotationMatrix();
    std::vector<Eigen::Matrix2d> hard = {Eigen::Matrix2d::Identity(), 1.3 * R, 0.7 * R,
                                         R * diag(1.2, 1.2 - 1e-9), R * diag(1.0, 1e-2)};
    if (D == 2) hard.insert(hard.end(), {diag(1.0, -0.5), R * diag(1.1, -0.3)});
    for (const Eigen::Matrix2d& A : hard) set.hard.push_back({T * A, T});
  }
  for (int k = 0; k < 4; ++k) set.rotations.push_back(source.rotation<D>());
  for (int k = 0; k < 6; ++k) {
    Direction direction{source.matrix<2, 2>(-1.0, 1.0).normalized(),
                        Eigen::Matrix<double, 1, 2>::Zero()};
    if (D == 3 && k % 2 == 1) direction.b = source.matrix<1, 2>(-1.0, 1.0).normalized();
    set.directions.push_back(direction);
  }
  return set;
}

const SampleSet<2>& planarSamples() {
  static const SampleSet<2> samples = makeSamples<2>();
  return samples;
}
const SampleSet<3>& clothSamples() {
  static const SampleSet<3> samples = makeSamples<3>();
  return samples;
}

template <int D>
Eigen::Matrix<double, 2 * D, 1> vec(const DefGrad<D>& M) {
  return Eigen::Map<const Eigen::Matrix<double, 2 * D, 1>>(M.data());
}

/// Runs measure<D>(samples) for planar and cloth elements and keeps the worse of the two, where
/// "worse" is the larger value (or the smaller with keepSmaller).
template <class Measure>
double worstOverDimensions(const Measure& measure, bool keepSmaller = false) {
  const double planar = measure(planarSamples());
  const double cloth = measure(clothSamples());
  return keepSmaller ? std::min(planar, cloth) : std::max(planar, cloth);
}

/// The measurements for one model. Model is one of the six materials or SquaredNormEnergy: the
/// same duck-typed interface (psi, pk1, projectedHessian, inDomain, mu, lambda).
template <class Model>
class Auditor {
 public:
  explicit Auditor(const Model& model)
      : model_(model), stiffness_(std::max(model.mu() + std::abs(model.lambda()), 1e-300)) {}

  double restEnergy() const {
    return worstOverDimensions([&](const auto& set) {
      double worst = 0.0;
      for (const auto& T : set.restFrames) {
        worst = std::max(worst, std::abs(psi(T, T)));
      }
      return worst;
    });
  }

  double restStress() const {
    return worstOverDimensions([&](const auto& set) {
      double worst = 0.0;
      for (const auto& T : set.restFrames) {
        worst = std::max(worst, model_.pk1(T, T).cwiseAbs().maxCoeff());
      }
      return worst;
    });
  }

  double minimumEnergy() const {
    return worstOverDimensions(
        [&](const auto& set) {
          double lowest = kInfinity;
          for (const auto& s : set.wide) {
            if (inDomain(s.F)) lowest = std::min(lowest, psi(s.F, s.T));
          }
          return lowest;
        },
        /*keepSmaller=*/true);
  }

  double rotationChange() const {
    return worstOverDimensions([&](const auto& set) {
      double worst = 0.0;
      for (const auto& s : set.wide) {
        if (!inDomain(s.F)) continue;
        const double reference = psi(s.F, s.T);
        for (const auto& Q : set.rotations) {
          const decltype(s.F) rotated = Q * s.F;
          if (!inDomain(rotated)) continue;
          worst = std::max(worst, std::abs(psi(rotated, s.T) - reference));
        }
      }
      return worst;
    });
  }

  /// The smallest p over all directions in |psi - psi_linear| ~ eps^p; +infinity if exact.
  /// The size of the difference at eps is max(|d(eps)|, |d(-eps)|) = |c3| eps^3 + |c4| eps^4 to
  /// leading orders, so a direction where the eps^3 and eps^4 terms cancel at one sign of eps does
  /// not spoil the estimate.
  double linearOrder() const {
    const LinearElasticity linear(Lame{model_.mu(), model_.lambda()});
    return worstOverDimensions(
        [&](const auto& set) {
          double lowest = kInfinity;
          for (const auto& T : set.restFrames) {
            for (const Direction& direction : set.directions) {
              const auto size = [&](double eps) {
                double largest = 0.0;
                for (double e : {eps, -eps}) {
                  const auto F = deformedAlong(T, direction, e);
                  largest = std::max(largest, std::abs(psi(F, T) - linear.psi(F, T)));
                }
                return largest;
              };
              const double coarse = size(1e-2), fine = size(1e-3);
              const double floor = kExactAgreement * stiffness_;
              if (coarse <= floor && fine <= floor) continue;  // exact in this direction
              // A difference that vanishes at the fine eps only (round-off) counts as a high
              // order; the guard keeps the ratio finite.
              lowest = std::min(lowest, std::log10(coarse / std::max(fine, floor * 1e-3)));
            }
          }
          return lowest;
        },
        /*keepSmaller=*/true);
  }

  /// Largest relative error of P against central differences of psi.
  double stressError() const {
    return worstOverDimensions([&](const auto& set) {
      double worst = 0.0;
      for (const auto* samples : {&set.moderate, &set.hard}) {
        for (const auto& s : *samples) {
          if (!inDomain(s.F)) continue;
          const auto P = model_.pk1(s.F, s.T);
          double error = 0.0;
          for (int i = 0; i < s.F.size(); ++i) {
            auto Fp = s.F, Fm = s.F;
            Fp.data()[i] += kFdStep;
            Fm.data()[i] -= kFdStep;
            const double fd = (psi(Fp, s.T) - psi(Fm, s.T)) / (2.0 * kFdStep);
            error = std::max(error, std::abs(fd - P.data()[i]));
          }
          worst = std::max(worst, error / std::max(P.cwiseAbs().maxCoeff(), stiffness_));
        }
      }
      return worst;
    });
  }

  /// Smallest eigenvalue of the projected Hessian, relative to its size.
  double smallestProjectedEigenvalue() const {
    return worstOverDimensions(
        [&](const auto& set) {
          double lowest = kInfinity;
          for (const auto* samples : {&set.wide, &set.hard}) {
            for (const auto& s : *samples) {
              if (!inDomain(s.F)) continue;
              const auto H = model_.projectedHessian(s.F, s.T);
              using Hessian = std::decay_t<decltype(H)>;
              const double smallest =
                  Eigen::SelfAdjointEigenSolver<Hessian>(H, Eigen::EigenvaluesOnly)
                      .eigenvalues()
                      .minCoeff();
              lowest = std::min(lowest, smallest / std::max(H.cwiseAbs().maxCoeff(), stiffness_));
            }
          }
          return lowest;
        },
        /*keepSmaller=*/true);
  }

  /// psi and the restoring force -P22 at the planar F = diag(1, s).
  AuditCriterion uniaxialFinite(const char* name, double s) const {
    const DefGrad<2> F = diag(1.0, s);
    const DefGrad<2> T = DefGrad<2>::Identity();
    AuditCriterion c{name, psi(F, T), false, false, "reported only"};
    c.pass = std::isfinite(c.measured);
    if (!inDomain(F)) c.note = "outside the domain (J <= 0): psi = +infinity, a barrier";
    return c;
  }
  AuditCriterion uniaxialRestoring(const char* name, double s) const {
    const DefGrad<2> F = diag(1.0, s);
    AuditCriterion c{name, kNotMeasured, false, false, "reported only"};
    if (!inDomain(F)) {
      c.note = "outside the domain (J <= 0): not measured";
      return c;
    }
    const DefGrad<2> T = DefGrad<2>::Identity();
    c.measured = -model_.pk1(F, T)(1, 1) + 0.0;  // + 0.0 reports a zero stress as 0, not -0
    c.pass = c.measured > kRestoringTolerance * stiffness_;
    return c;
  }

  double stiffness() const { return stiffness_; }

 private:
  template <int D>
  double psi(const DefGrad<D>& F, const DefGrad<D>& T) const {
    return model_.template psi<D>(F, T);
  }
  template <int D>
  bool inDomain(const DefGrad<D>& F) const {
    return model_.template inDomain<D>(F);
  }
  template <int D>
  static DefGrad<D> deformedAlong(const DefGrad<D>& T, const Direction& d, double eps) {
    return T * (Eigen::Matrix2d::Identity() + eps * d.H) + eps * unitNormalTimes<D>(T, d.b);
  }

  const Model& model_;
  double stiffness_;
};

template <class Model>
MaterialAudit audit(const std::string& name, const Model& model, bool counterexample) {
  const Auditor<Model> auditor(model);
  const double k = auditor.stiffness();
  MaterialAudit a;
  a.model = name;
  a.counterexample = counterexample;
  const auto add = [&](const char* criterionName, double measured, bool pass) {
    a.criteria.push_back({criterionName, measured, pass, true, ""});
  };
  const double restEnergy = auditor.restEnergy();
  add(criterion::kRestEnergy, restEnergy, restEnergy <= kRestTolerance * k);
  const double restStress = auditor.restStress();
  add(criterion::kRestStress, restStress, restStress <= kRestTolerance * k);
  const double lowest = auditor.minimumEnergy();
  add(criterion::kNonNegative, lowest, lowest >= -kNegativeTolerance * k);
  const double change = auditor.rotationChange();
  add(criterion::kRotationInvariant, change, change <= kInvarianceTolerance * k);
  if (!Model::kRotationInvariant) {
    a.criteria.back().decides = false;
    a.criteria.back().note = "exempt: the small-strain reference is not rotation invariant";
  }
  const double order = auditor.linearOrder();
  add(criterion::kLinearOrder, order, order >= kMinimumLinearOrder);
  if (std::isinf(order)) a.criteria.back().note = "exact";
  const double stressError = auditor.stressError();
  add(criterion::kStressMatchesFd, stressError, stressError <= kFdTolerance);
  const double smallest = auditor.smallestProjectedEigenvalue();
  add(criterion::kHessianPsd, smallest, smallest >= -kPsdTolerance);
  a.criteria.push_back(auditor.uniaxialFinite(criterion::kCollapseFinite, 0.0));
  a.criteria.push_back(auditor.uniaxialRestoring(criterion::kCollapseRestoring, 0.0));
  a.criteria.push_back(auditor.uniaxialFinite(criterion::kInversionFinite, -0.5));
  a.criteria.push_back(auditor.uniaxialRestoring(criterion::kInversionRestoring, -0.5));

  std::string failed;
  for (const AuditCriterion& c : a.criteria) {
    if (c.decides && !c.pass) failed += (failed.empty() ? "" : ", ") + c.name;
  }
  a.accepted = failed.empty();
  a.verdict = a.accepted ? "accepted" : "rejected: " + failed;
  return a;
}

}  // namespace

const AuditCriterion& MaterialAudit::criterion(const std::string& name) const {
  for (const AuditCriterion& c : criteria) {
    if (c.name == name) return c;
  }
  throw std::out_of_range("material audit: no criterion '" + name + "'");
}

std::vector<MaterialAudit> auditMaterials(const Lame& lame) {
  std::vector<MaterialAudit> audits;
  for (const std::string& name : materialNames()) {
    std::visit([&](const auto& model) { audits.push_back(audit(name, model, false)); },
               *makeMaterial(name, lame));
  }
  audits.push_back(audit(kSquaredNormName, SquaredNormEnergy(lame.mu, 0.0), true));
  audits.push_back(audit(kShiftedSquaredNormName, SquaredNormEnergy(lame.mu, 2.0), true));
  return audits;
}

}  // namespace fem_cloth
