// Helpers of the bending tests (test_bending.cpp, test_bending_midedge.cpp): meshes, shapes,
// evaluation shortcuts and central-difference checks.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "fem_cloth/core/bending.h"

namespace fem_cloth::test {

struct Cloth {
  std::shared_ptr<Mesh> mesh;
  std::shared_ptr<RestState> rest;
};

inline Mesh gridMesh(int rows, int cols, double width, double height) {
  GridSpec spec;
  spec.rows = rows;
  spec.cols = cols;
  spec.width = width;
  spec.height = height;
  return *makeGrid(spec);
}

inline Cloth withRest(Mesh mesh) {
  Cloth c;
  c.mesh = std::make_shared<Mesh>(std::move(mesh));
  c.rest = std::make_shared<RestState>(*computeRestState(*c.mesh));
  return c;
}

inline std::unique_ptr<EnergyTerm> makeTerm(const Cloth& c, const std::string& model, double k) {
  auto term = makeBendingTerm(*c.mesh, *c.rest, model, k);
  EXPECT_TRUE(term.ok()) << (term.ok() ? "" : term.error());
  return std::move(term).value();
}

inline SparseHessian patternFor(const Mesh& mesh, EnergyTerm& term) {
  std::vector<std::vector<Index>> stencils;
  term.appendStencils(&stencils);
  SparseHessian H(mesh.numVertices(), mesh.dim, stencils);
  term.bindHessian(H);
  return H;
}

inline double energyOf(EnergyTerm& term, const VectorX& x) { return term.evaluate(x, EvalRequest{}).energy; }

inline VectorX gradientOf(EnergyTerm& term, const VectorX& x) {
  VectorX g = VectorX::Zero(x.size());
  EvalRequest request;
  request.energy = false;
  request.gradient = &g;
  term.evaluate(x, request);
  return g;
}

inline Eigen::MatrixXd hessianOf(EnergyTerm& term, SparseHessian& H, const VectorX& x, HessianMode mode) {
  H.setZero();
  EvalRequest request;
  request.energy = false;
  request.hessian = &H;
  request.hessianMode = mode;
  term.evaluate(x, request);
  return Eigen::MatrixXd(H.matrix());
}

inline VectorX randomlyPerturbed(const VectorX& x0, double amount, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-amount, amount);
  VectorX x = x0;
  for (Eigen::Index i = 0; i < x.size(); ++i) x[i] += u(rng);
  return x;
}

/// A smooth non-flat shape: z += amplitude * sin(3 x) cos(2 y) on every vertex.
inline VectorX wavy(const VectorX& flat, double amplitude) {
  VectorX x = flat;
  for (Eigen::Index i = 0; i < x.size() / 3; ++i) {
    x[3 * i + 2] += amplitude * std::sin(3.0 * flat[3 * i]) * std::cos(2.0 * flat[3 * i + 1]);
  }
  return x;
}

/// A bent state away from the rest shape (hinges turn by up to ~0.5 rad on the small grids):
/// the wave above plus random noise.
inline VectorX bentState(const VectorX& rest, unsigned seed) {
  return randomlyPerturbed(wavy(rest, 0.15), 0.03, seed);
}

/// Rolls a sheet lying in the XY plane (z = 0, x >= 0) around an axis parallel to y at height
/// `radius`: (u, v, 0) -> (R sin(u/R), v, R (1 - cos(u/R))). The map keeps the arc length u,
/// so it is an isometry of the continuous sheet, with principal curvatures 1/R and 0.
inline VectorX rolledIntoCylinder(const VectorX& flat, double radius) {
  VectorX x = flat;
  for (Eigen::Index i = 0; i < x.size() / 3; ++i) {
    const double u = flat[3 * i];
    x[3 * i] = radius * std::sin(u / radius);
    x[3 * i + 2] = radius * (1.0 - std::cos(u / radius));
  }
  return x;
}

/// A rows x cols grid (width x height) whose rest shape is rolled into a cylinder of `radius`;
/// `flat` gets the flat grid's positions.
inline Cloth rolledGridCloth(int rows, int cols, double width, double height, double radius,
                             VectorX* flat) {
  Mesh mesh = gridMesh(rows, cols, width, height);
  *flat = mesh.restPositions;
  mesh.restPositions = rolledIntoCylinder(*flat, radius);
  return withRest(mesh);
}

/// Rows of vertices `spacing` apart, every other row shifted by half a spacing, so that all
/// triangles are equilateral and the edges run in three directions (0 and +-60 degrees).
/// Its area is (rows - 1)(cols - 1) spacing * height, height = sqrt(3)/2 spacing.
inline Mesh equilateralLattice(int rows, int cols, double spacing) {
  Mesh mesh;
  mesh.dim = 3;
  const double rowHeight = std::sqrt(3.0) / 2.0 * spacing;
  mesh.restPositions.resize(3 * rows * cols);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const int i = r * cols + c;
      mesh.restPositions.segment<3>(3 * i) << c * spacing + (r % 2) * spacing / 2, r * rowHeight, 0;
    }
  }
  for (int r = 0; r + 1 < rows; ++r) {
    // The row with the larger shift is the "right" one of each pair.
    const int low = r * cols, high = (r + 1) * cols;
    for (int c = 0; c + 1 < cols; ++c) {
      if (r % 2 == 0) {
        mesh.triangles.push_back({low + c, low + c + 1, high + c});
        mesh.triangles.push_back({low + c + 1, high + c + 1, high + c});
      } else {
        mesh.triangles.push_back({low + c, high + c + 1, high + c});
        mesh.triangles.push_back({low + c, low + c + 1, high + c + 1});
      }
    }
  }
  return mesh;
}

/// Largest |FD - analytic| over all entries for each step h, relative to 1 + max |analytic|.
struct FiniteDifferenceErrors {
  std::vector<double> gradient, hessian;
};

inline FiniteDifferenceErrors finiteDifferenceErrors(EnergyTerm& term, SparseHessian& H, const VectorX& x,
                                              const std::vector<double>& steps) {
  const VectorX g = gradientOf(term, x);
  const Eigen::MatrixXd K = hessianOf(term, H, x, HessianMode::Exact);
  const double gradScale = 1.0 + g.cwiseAbs().maxCoeff();
  const double hessScale = 1.0 + K.cwiseAbs().maxCoeff();
  FiniteDifferenceErrors errors;
  for (double h : steps) {
    double gradError = 0.0, hessError = 0.0;
    for (Eigen::Index i = 0; i < x.size(); ++i) {
      VectorX xp = x, xm = x;
      xp[i] += h;
      xm[i] -= h;
      const double fd = (energyOf(term, xp) - energyOf(term, xm)) / (2 * h);
      gradError = std::max(gradError, std::abs(fd - g[i]));
      const VectorX column = (gradientOf(term, xp) - gradientOf(term, xm)) / (2 * h);
      hessError = std::max(hessError, (column - K.col(i)).cwiseAbs().maxCoeff());
    }
    errors.gradient.push_back(gradError / gradScale);
    errors.hessian.push_back(hessError / hessScale);
  }
  return errors;
}

/// Central differences: the error falls like h^2 until round-off (~ eps / h) takes over.
inline void expectConverging(const std::vector<double>& e, const std::string& what) {
  const double roundOff = 1e-9;
  EXPECT_LT(*std::min_element(e.begin(), e.end()), 1e-7) << what;
  for (std::size_t i = 0; i + 2 < e.size(); ++i) {
    if (e[i] > roundOff) {
      EXPECT_LT(e[i + 1], 0.05 * e[i]) << what << ": error does not fall like h^2";
    }
  }
}

inline Eigen::Matrix3d someRotation() {
  return Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
}

inline VectorX rigidlyMoved(const VectorX& x, const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  VectorX y(x.size());
  for (Eigen::Index i = 0; i < x.size() / 3; ++i) y.segment<3>(3 * i) = R * x.segment<3>(3 * i) + t;
  return y;
}

}  // namespace fem_cloth::test
