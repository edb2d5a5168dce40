// Optional forms of an energy term, for solvers that do not minimise the energy by Newton's
// method. A term offers one by returning it from EnergyTerm::constraintForm() or
// projectiveForm(); the solvers that need a form ask for it and refuse a term without it, and
// terms (and materials) that have no such form need not pretend to.
#pragma once

#include <Eigen/SparseCore>
#include <vector>

#include "fem_cloth/core/conventions.h"

namespace fem_cloth {

/// Constraint form, for solvers that visit one element at a time (XPBD, integrators/xpbd.h):
/// the energy of element e is U_e = 1/2 C_e^T K_e C_e with k signed constraint functions C_e(x)
/// (zero at rest) and a constant k x k matrix K_e.
class ConstraintForm {
 public:
  static constexpr int kMaxConstraintsPerElement = 3;
  static constexpr int kMaxElementDofs = 12;
  virtual ~ConstraintForm() = default;
  virtual Index numElements() const = 0;
  virtual int verticesPerElement() const = 0;
  virtual int constraintsPerElement() const = 0;
  /// The element's vertex indices (verticesPerElement() of them).
  virtual const Index* elementVertices(Index element) const = 0;
  /// C (k values) and dC/dx (k rows of verticesPerElement() * dim entries, row-major, element
  /// vertex order) at x; false outside the domain. Thread-safe.
  virtual bool elementConstraints(Index element, const VectorX& x, double* C, double* jacobian) const = 0;
  /// K_e (k x k, row-major), constant.
  virtual void elementConstraintStiffness(Index element, double* K) const = 0;
};

/// Projective form, for Projective Dynamics (Bouaziz, Martin, Liu, Kavan & Pauly, "Projective
/// Dynamics: Fusing Constraint Projections for Fast Simulation", 2014; integrators/
/// projective_dynamics.h): the energy is
///   E(x) = sum_i w_i / 2 |S_i x - p_i(x)|^2,  p_i(x) = argmin over the element's rest-shape set,
/// with S_i acting on every coordinate alike. Then the system matrix sum_i w_i S_i^T S_i is
/// constant and the same scalar (n x n) matrix for every coordinate.
class ProjectiveForm {
 public:
  virtual ~ProjectiveForm() = default;
  /// Adds the scalar matrix sum_i w_i S_i^T S_i (vertex indices, n x n) as triplets.
  virtual void appendProjectiveMatrix(std::vector<Eigen::Triplet<double>>* triplets) const = 0;
  /// The local step: rhs += sum_i w_i S_i^T p_i(x) (a flat d*n vector).
  virtual void addProjectiveRhs(const VectorX& x, VectorX* rhs) = 0;
};

}  // namespace fem_cloth
