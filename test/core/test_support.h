// Shared scaffolding of the simulation tests: scenes built in code, a stepping loop that stops
// at the first failed step, and measurements computed here from positions, velocities and
// masses alone (centre of mass, momentum, kinetic and gravitational energy, triangle area
// ratios, deformation gradients), so that expected values never come from the code under test.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "fem_cloth/core/scene.h"

namespace fem_cloth::test {

constexpr double kG = 9.81;  // m/s^2

/// The integrators in the order the scene format lists them.
inline const std::vector<std::string>& allIntegrators() { return integratorNames(); }

/// The integrators that simulate planar sheets (dim 2) with any material: all but projective
/// dynamics, which is limited to ARAP cloth (its scope is tested in test_projective_dynamics).
inline std::vector<std::string> planarIntegrators() {
  std::vector<std::string> names;
  for (const std::string& n : integratorNames()) {
    if (n != "projective_dynamics") names.push_back(n);
  }
  return names;
}

/// The material a cloth test uses with `integrator`: `preferred`, except ARAP for projective
/// dynamics, which simulates nothing else.
inline std::string clothMaterialFor(const std::string& integrator, const std::string& preferred) {
  return integrator == "projective_dynamics" ? "arap" : preferred;
}

/// A flat grid sheet, 1 kg/m^2 (density 1000 kg/m^3 x thickness 1 mm), StVK with membrane
/// moduli mu = lambda = `membraneModulus` (N/m), no bending, no damping, no pins, gravity -g z
/// (or none for planar sheets). rows = cols = n vertices on a side x side square. Projective
/// dynamics gets ARAP with the same mu (see clothMaterialFor).
inline Scene gridScene(int dim, int n, double side, const std::string& integrator,
                       double membraneModulus = 100.0) {
  Scene s;
  s.name = "test";
  s.meshType = MeshType::Grid;
  s.grid.dim = dim;
  s.dim = dim;
  s.grid.rows = n;
  s.grid.cols = n;
  s.grid.width = side;
  s.grid.height = side;
  s.materialModel = clothMaterialFor(integrator, "stvk");
  s.thickness = 1e-3;
  s.density = 1000.0;
  s.mu = membraneModulus / s.thickness;
  s.lambda = membraneModulus / s.thickness;
  s.bendingStiffness = 0.0;
  s.gravity = dim == 3 ? Eigen::Vector3d(0.0, 0.0, -kG) : Eigen::Vector3d::Zero();
  s.integrator = integrator;
  s.dt = 0.01;
  return s;
}

/// buildSimulation, throwing (which gtest reports as a failure) on error.
inline Simulation mustBuild(const Scene& scene) {
  Expected<Simulation> sim = buildSimulation(scene);
  if (!sim) throw std::runtime_error("buildSimulation failed: " + sim.error());
  return std::move(sim).value();
}

/// Steps `steps` times (applying the scene script before each step), calling `after` after each
/// accepted step with its 1-based index. Returns the failed step's error, or "" if all passed.
inline std::string run(Simulation& sim, int steps,
                       const std::function<void(int, const StepReport&)>& after = {}) {
  for (int k = 1; k <= steps; ++k) {
    if (Status s = sim.script.applyDue(*sim.simulator); !s) return s.error();
    const StepReport r = sim.simulator->step();
    if (!r.ok) return "step " + std::to_string(k) + ": " + r.error;
    if (after) after(k, r);
  }
  return "";
}

/// A vertex's position (zeros beyond dim).
inline Eigen::Vector3d vertexPosition(const Simulator& sim, Index i) {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  const int d = sim.dim();
  p.head(d) = sim.state().x.segment(d * i, d);
  return p;
}

/// Mass-weighted mean of a per-DOF field (positions: the centre of mass), zeros beyond dim.
inline Eigen::Vector3d massMean(const Model& model, const VectorX& field) {
  const int d = model.dim();
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (Index i = 0; i < model.numVertices(); ++i) {
    sum.head(d) += model.vertexMasses()[i] * field.segment(d * i, d);
  }
  return sum / model.totalMass();
}

/// Linear momentum sum m_i v_i (kg m/s).
inline Eigen::Vector3d momentum(const Model& model, const VectorX& v) {
  return massMean(model, v) * model.totalMass();
}

/// Kinetic energy 1/2 v^T M v (J).
inline double kineticEnergy(const Model& model, const VectorX& v) {
  double e = 0.0;
  const int d = model.dim();
  for (Index i = 0; i < model.numVertices(); ++i) {
    e += 0.5 * model.vertexMasses()[i] * v.segment(d * i, d).squaredNorm();
  }
  return e;
}

/// Gravitational potential -sum m_i g . x_i (J), relative to the origin.
inline double gravityEnergy(const Model& model, const VectorX& x, const Eigen::Vector3d& g) {
  const int d = model.dim();
  double e = 0.0;
  for (Index i = 0; i < model.numVertices(); ++i) {
    e -= model.vertexMasses()[i] * g.head(d).dot(x.segment(d * i, d));
  }
  return e;
}

/// Kinetic + elastic + gravitational energy (J); the elastic part is the model's energy, whose
/// derivatives are checked against finite differences in test_membrane and test_bending.
inline double mechanicalEnergy(Simulator& sim) {
  const Model::Energies elastic = sim.model().energies(sim.state().x);
  return kineticEnergy(sim.model(), sim.state().v) + elastic.total() +
         gravityEnergy(sim.model(), sim.state().x, sim.settings().gravity);
}

/// Deformation gradient of triangle t measured in its own rest plane: F^T F = G^T G with
/// G = Ds Dm^-1 where Ds, Dm are the deformed and rest edge matrices written in any
/// orthonormal frame of each plane; for planar meshes F itself (2 x 2).
inline Eigen::Matrix2d planarDeformationGradient(const Mesh& mesh, const VectorX& x, Index t) {
  const int d = mesh.dim;
  const Triangle& tri = mesh.triangles[t];
  auto edges = [&](const VectorX& p) {
    Eigen::MatrixXd D(d, 2);
    D.col(0) = p.segment(d * tri[1], d) - p.segment(d * tri[0], d);
    D.col(1) = p.segment(d * tri[2], d) - p.segment(d * tri[0], d);
    if (d == 2) return Eigen::Matrix2d(D);
    // Gram-Schmidt frame of the triangle's plane; the result is unique up to a rotation.
    const Eigen::Vector3d e0 = D.col(0).normalized();
    const Eigen::Vector3d e1 = (D.col(1) - e0.dot(D.col(1)) * e0).normalized();
    Eigen::Matrix2d local;
    local << e0.dot(D.col(0)), e0.dot(D.col(1)), e1.dot(D.col(0)), e1.dot(D.col(1));
    return local;
  };
  return edges(x) * edges(mesh.restPositions).inverse();
}

/// Area ratio J = deformed / rest area of every triangle: signed (negative when inverted) for
/// planar meshes, unsigned for cloth.
inline std::vector<double> areaRatios(const Mesh& mesh, const VectorX& x) {
  std::vector<double> J;
  const int d = mesh.dim;
  auto area = [&](const VectorX& p, const Triangle& tri) {
    const VectorX a = p.segment(d * tri[1], d) - p.segment(d * tri[0], d);
    const VectorX b = p.segment(d * tri[2], d) - p.segment(d * tri[0], d);
    if (d == 2) return 0.5 * (a[0] * b[1] - a[1] * b[0]);
    return 0.5 * Eigen::Vector3d(a).cross(Eigen::Vector3d(b)).norm();
  };
  for (const Triangle& tri : mesh.triangles) {
    J.push_back(area(x, tri) / area(mesh.restPositions, tri));
  }
  return J;
}

/// Largest edge stretch l / L - 1 over all triangle edges.
inline double maxEdgeStretch(const Mesh& mesh, const VectorX& x) {
  const int d = mesh.dim;
  double worst = -1.0;
  for (const Triangle& tri : mesh.triangles) {
    for (int e = 0; e < 3; ++e) {
      const Index a = tri[e], b = tri[(e + 1) % 3];
      const double l = (x.segment(d * a, d) - x.segment(d * b, d)).norm();
      const double L = (mesh.restPositions.segment(d * a, d) - mesh.restPositions.segment(d * b, d)).norm();
      worst = std::max(worst, l / L - 1.0);
    }
  }
  return worst;
}

inline double minAreaRatio(const Mesh& mesh, const VectorX& x) {
  double m = std::numeric_limits<double>::infinity();
  for (double J : areaRatios(mesh, x)) m = std::min(m, J);
  return m;
}

inline double maxAbs(const VectorX& v) { return v.size() ? v.cwiseAbs().maxCoeff() : 0.0; }

/// The first number that follows `marker` in `text` (NaN if none).
inline double numberAfter(const std::string& text, const std::string& marker) {
  const auto at = text.find(marker);
  if (at == std::string::npos) return std::nan("");
  try {
    return std::stod(text.substr(at + marker.size()));
  } catch (const std::exception&) {
    return std::nan("");
  }
}

/// Natural angular frequencies (rad/s, ascending) of small oscillations about x with the
/// vertices in `fixed` held: the square roots of the eigenvalues of M^-1/2 K M^-1/2, with the
/// stiffness K by central differences of the model's gradient (dense: small meshes only).
inline std::vector<double> naturalFrequencies(Model& model, const VectorX& x,
                                              const std::vector<Index>& fixed = {}) {
  const Index n = model.numDofs();
  const int d = model.dim();
  auto gradient = [&](const VectorX& at) {
    VectorX g = VectorX::Zero(n);
    EvalRequest request;
    request.energy = false;
    request.gradient = &g;
    model.evaluate(at, request);
    return g;
  };
  std::vector<char> isFixed(n, 0);
  for (Index v : fixed) {
    for (int k = 0; k < d; ++k) isFixed[d * v + k] = 1;
  }
  std::vector<Index> freeDofs;
  for (Index i = 0; i < n; ++i) {
    if (!isFixed[i]) freeDofs.push_back(i);
  }
  const Index m = static_cast<Index>(freeDofs.size());
  Eigen::MatrixXd K(m, m);
  const double eps = 1e-6;
  for (Index c = 0; c < m; ++c) {
    VectorX xp = x, xm = x;
    xp[freeDofs[c]] += eps;
    xm[freeDofs[c]] -= eps;
    const VectorX column = (gradient(xp) - gradient(xm)) / (2.0 * eps);
    for (Index r = 0; r < m; ++r) {
      K(r, c) = column[freeDofs[r]] / std::sqrt(model.dofMasses()[freeDofs[r]] *
                                                 model.dofMasses()[freeDofs[c]]);
    }
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(0.5 * (K + K.transpose()),
                                                              Eigen::EigenvaluesOnly);
  std::vector<double> omega;
  for (Index i = 0; i < m; ++i) omega.push_back(std::sqrt(std::max(solver.eigenvalues()[i], 0.0)));
  return omega;
}

}  // namespace fem_cloth::test
