// The material audit: the six models are accepted, the two counterexamples rejected for the
// reasons they were built to show, and the reported numbers at rest, collapse and inversion match
// hand calculations.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <stdexcept>
#include <string>

#include "fem_cloth/core/material_audit.h"

using namespace fem_cloth;
namespace criterion = audit_criterion;

namespace {

constexpr double kMu = 1.3;
constexpr double kLambda = 2.1;

std::map<std::string, MaterialAudit> auditByName() {
  std::map<std::string, MaterialAudit> byName;
  for (const MaterialAudit& a : auditMaterials(Lame{kMu, kLambda})) byName[a.model] = a;
  return byName;
}

const std::vector<std::string> kModels = {"linear",      "stvk",       "corotational",
                                          "arap",        "neo_hookean", "stable_neo_hookean"};
const std::vector<std::string> kDecidingCriteria = {
    criterion::kRestEnergy,   criterion::kRestStress,       criterion::kNonNegative,
    criterion::kLinearOrder,  criterion::kStressMatchesFd,  criterion::kHessianPsd};

}  // namespace

TEST(MaterialAudit, ListsTheSixModelsThenTheTwoCounterexamples) {
  const std::vector<MaterialAudit> audits = auditMaterials(Lame{kMu, kLambda});
  ASSERT_EQ(audits.size(), 8u);
  for (std::size_t i = 0; i < kModels.size(); ++i) {
    EXPECT_EQ(audits[i].model, kModels[i]);
    EXPECT_FALSE(audits[i].counterexample);
  }
  EXPECT_EQ(audits[6].model, "norm_squared");
  EXPECT_EQ(audits[7].model, "norm_squared_minus_2");
  EXPECT_TRUE(audits[6].counterexample && audits[7].counterexample);
  for (const MaterialAudit& a : audits) EXPECT_EQ(a.criteria.size(), 11u) << a.model;
}

TEST(MaterialAudit, AcceptsTheSixModels) {
  const auto audits = auditByName();
  for (const std::string& name : kModels) {
    const MaterialAudit& a = audits.at(name);
    EXPECT_TRUE(a.accepted) << name << ": " << a.verdict;
    EXPECT_EQ(a.verdict, "accepted") << name;
    for (const std::string& c : kDecidingCriteria) {
      EXPECT_TRUE(a.criterion(c).decides) << name << ", " << c;
      EXPECT_TRUE(a.criterion(c).pass) << name << ", " << c << ": " << a.criterion(c).measured;
    }
    // Agreement with linear elasticity to second order: |psi - psi_linear| ~ eps^3.
    const double order = a.criterion(criterion::kLinearOrder).measured;
    if (name == "linear") {
      EXPECT_TRUE(std::isinf(order) && order > 0.0) << order;
    } else {
      EXPECT_GT(order, 2.8) << name;
      EXPECT_LT(order, 3.5) << name;
    }
    EXPECT_LT(a.criterion(criterion::kRestEnergy).measured, 1e-13) << name;
    EXPECT_LT(a.criterion(criterion::kStressMatchesFd).measured, 1e-7) << name;
  }
}

TEST(MaterialAudit, LinearIsExemptFromRotationInvarianceButItIsReported) {
  const auto audits = auditByName();
  const AuditCriterion& linear = audits.at("linear").criterion(criterion::kRotationInvariant);
  EXPECT_FALSE(linear.decides);
  EXPECT_FALSE(linear.pass);
  // Rotating an element by theta costs 2 (mu + lambda) (cos theta - 1)^2 at rest; the samples
  // include deformed elements turned by large angles, so the change is of order mu + lambda.
  EXPECT_GT(linear.measured, 0.1 * (kMu + kLambda));
  EXPECT_NE(linear.note.find("exempt"), std::string::npos);
  for (const std::string& name : kModels) {
    if (name == "linear") continue;
    const AuditCriterion& c = audits.at(name).criterion(criterion::kRotationInvariant);
    EXPECT_TRUE(c.decides && c.pass) << name << ": " << c.measured;
  }
}

TEST(MaterialAudit, RejectsSquaredNormBecauseRestIsNotFree) {
  const MaterialAudit a = auditByName().at("norm_squared");
  EXPECT_FALSE(a.accepted);
  // psi(T) = mu |T|^2 = 2 mu for any orthonormal frame; P(T) = 2 mu T, whose largest entry is 2 mu
  // for the planar T = I.
  EXPECT_NEAR(a.criterion(criterion::kRestEnergy).measured, 2.0 * kMu, 1e-12);
  EXPECT_FALSE(a.criterion(criterion::kRestEnergy).pass);
  EXPECT_NEAR(a.criterion(criterion::kRestStress).measured, 2.0 * kMu, 1e-12);
  EXPECT_FALSE(a.criterion(criterion::kRestStress).pass);
  // The energy 2 mu at rest does not vanish as eps -> 0: order 0.
  EXPECT_NEAR(a.criterion(criterion::kLinearOrder).measured, 0.0, 0.05);
  EXPECT_FALSE(a.criterion(criterion::kLinearOrder).pass);
  // Everything else about it is fine: it is rejected for its rest state only.
  for (const char* c : {criterion::kNonNegative, criterion::kRotationInvariant,
                        criterion::kStressMatchesFd, criterion::kHessianPsd}) {
    EXPECT_TRUE(a.criterion(c).pass) << c;
  }
  EXPECT_EQ(a.verdict, "rejected: rest energy, rest stress, linear order");
}

TEST(MaterialAudit, RejectsShiftedSquaredNormBecauseItGoesNegative) {
  const MaterialAudit a = auditByName().at("norm_squared_minus_2");
  EXPECT_FALSE(a.accepted);
  EXPECT_LT(a.criterion(criterion::kRestEnergy).measured, 1e-14);
  EXPECT_TRUE(a.criterion(criterion::kRestEnergy).pass);
  // Zero at rest but not stationary: P(I) = 2 mu I ...
  EXPECT_NEAR(a.criterion(criterion::kRestStress).measured, 2.0 * kMu, 1e-12);
  EXPECT_FALSE(a.criterion(criterion::kRestStress).pass);
  // ... so compression lowers it below zero; the samples include F = 0, where psi = -2 mu, and
  // psi >= -2 mu everywhere.
  EXPECT_NEAR(a.criterion(criterion::kNonNegative).measured, -2.0 * kMu, 1e-12);
  EXPECT_FALSE(a.criterion(criterion::kNonNegative).pass);
  // psi - psi_linear = 2 mu eps tr H + O(eps^2): first order.
  EXPECT_NEAR(a.criterion(criterion::kLinearOrder).measured, 1.0, 0.05);
  for (const char* c : {criterion::kRotationInvariant, criterion::kStressMatchesFd,
                        criterion::kHessianPsd}) {
    EXPECT_TRUE(a.criterion(c).pass) << c;
  }
  EXPECT_EQ(a.verdict, "rejected: rest stress, non-negative, linear order");
}

TEST(MaterialAudit, ReportsCollapseAndInversionAsHandCalculationsSay) {
  const auto audits = auditByName();
  // Reported only: none of these decides a verdict.
  for (const auto& [name, a] : audits) {
    for (const char* c : {criterion::kCollapseFinite, criterion::kCollapseRestoring,
                          criterion::kInversionFinite, criterion::kInversionRestoring}) {
      EXPECT_FALSE(a.criterion(c).decides) << name << ", " << c;
    }
  }
  const auto measured = [&](const std::string& model, const char* c) {
    return audits.at(model).criterion(c).measured;
  };
  // Along F = diag(1, s):
  // StVK: psi = mu/4 (s^2 - 1)^2 + lambda/8 (s^2 - 1)^2, P22 = (mu + lambda/2) (s^2 - 1) s.
  const double stvkStiffness = kMu + 0.5 * kLambda;
  EXPECT_NEAR(measured("stvk", criterion::kCollapseFinite), 0.25 * stvkStiffness, 1e-14);
  EXPECT_EQ(measured("stvk", criterion::kCollapseRestoring), 0.0);
  EXPECT_FALSE(audits.at("stvk").criterion(criterion::kCollapseRestoring).pass);
  EXPECT_NEAR(measured("stvk", criterion::kInversionRestoring), -0.375 * stvkStiffness, 1e-14);
  EXPECT_FALSE(audits.at("stvk").criterion(criterion::kInversionRestoring).pass);
  // Stable Neo-Hookean: psi = (2 mu + lambda)/2 (s - 1)^2, -P22 = (2 mu + lambda)(1 - s).
  const double snh = 2.0 * kMu + kLambda;
  EXPECT_NEAR(measured("stable_neo_hookean", criterion::kCollapseFinite), 0.5 * snh, 1e-14);
  EXPECT_NEAR(measured("stable_neo_hookean", criterion::kCollapseRestoring), snh, 1e-14);
  EXPECT_NEAR(measured("stable_neo_hookean", criterion::kInversionFinite), 0.5 * snh * 2.25,
              1e-13);
  EXPECT_NEAR(measured("stable_neo_hookean", criterion::kInversionRestoring), 1.5 * snh, 1e-13);
  // Linear: eps = diag(0, s - 1): psi = (mu + lambda/2)(s - 1)^2, -P22 = (2 mu + lambda)(1 - s).
  EXPECT_NEAR(measured("linear", criterion::kCollapseFinite), kMu + 0.5 * kLambda, 1e-14);
  EXPECT_NEAR(measured("linear", criterion::kInversionRestoring), 1.5 * (2 * kMu + kLambda),
              1e-13);
  // Neo-Hookean is a barrier: infinite at J <= 0, not measured there, never NaN for psi.
  const AuditCriterion& nhFinite = audits.at("neo_hookean").criterion(criterion::kCollapseFinite);
  EXPECT_TRUE(std::isinf(nhFinite.measured) && nhFinite.measured > 0.0);
  EXPECT_FALSE(nhFinite.pass);
  EXPECT_TRUE(std::isnan(measured("neo_hookean", criterion::kInversionRestoring)));
  EXPECT_NE(audits.at("neo_hookean").criterion(criterion::kInversionRestoring).note.find("domain"),
            std::string::npos);
  // Corotational and ARAP restore through inversion: R = I at diag(1, -0.5) with the signed SVD,
  // P22 = 2 mu (s - 1) + lambda (s - 1) for corotational, 2 mu (s - 1) for ARAP.
  EXPECT_NEAR(measured("corotational", criterion::kInversionRestoring), 1.5 * (2 * kMu + kLambda),
              1e-13);
  EXPECT_NEAR(measured("arap", criterion::kInversionRestoring), 3.0 * kMu, 1e-13);
}

TEST(MaterialAudit, IsDeterministic) {
  const auto first = auditMaterials(Lame{kMu, kLambda});
  const auto second = auditMaterials(Lame{kMu, kLambda});
  ASSERT_EQ(first.size(), second.size());
  for (std::size_t i = 0; i < first.size(); ++i) {
    for (std::size_t j = 0; j < first[i].criteria.size(); ++j) {
      const double a = first[i].criteria[j].measured, b = second[i].criteria[j].measured;
      EXPECT_TRUE(a == b || (std::isnan(a) && std::isnan(b))) << first[i].model;
    }
  }
}

TEST(MaterialAudit, UnknownCriterionThrows) {
  EXPECT_THROW(auditMaterials(Lame{kMu, kLambda})[0].criterion("elegance"), std::out_of_range);
}
