// The membrane (in-plane) energy of a triangle mesh: E = sum_t restArea_t psi(F_t), with psi the
// material's energy per unit rest area (so the material's Lame parameters are membrane moduli in
// N/m: volumetric moduli times thickness).
#pragma once

#include <memory>

#include "fem_cloth/core/energy_term.h"
#include "fem_cloth/core/materials/materials.h"
#include "fem_cloth/core/mesh.h"
#include "fem_cloth/core/rest_state.h"

namespace fem_cloth {

/// Element kernels (Sifakis & Barbic 2012, section 4): with F = sum_a x_a g_a^T (g_a the rows of
/// the rest state's shape gradients G), the gradient on vertex a is A P g_a and the Hessian block
/// (a, b) is A sum_{c,e} g_a[c] g_b[e] H_(ce), where H_(ce) is the d x d block of d^2psi/dF^2
/// coupling column c of F with column e.
template <int D>
ElementVector<D> membraneElementGradient(double restArea, const DefGrad<D>& P,
                                         const Eigen::Matrix<double, 3, 2>& G) {
  ElementVector<D> g;
  for (int a = 0; a < 3; ++a) g.template segment<D>(D * a) = restArea * (P * G.row(a).transpose());
  return g;
}

template <int D>
ElementMatrix<D> membraneElementHessian(double restArea, const StressHessian<D>& H,
                                        const Eigen::Matrix<double, 3, 2>& G) {
  ElementMatrix<D> K;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      Eigen::Matrix<double, D, D> block = Eigen::Matrix<double, D, D>::Zero();
      for (int c = 0; c < 2; ++c) {
        for (int e = 0; e < 2; ++e) {
          block += (G(a, c) * G(b, e)) * H.template block<D, D>(D * c, D * e);
        }
      }
      K.template block<D, D>(D * a, D * b) = restArea * block;
    }
  }
  return K;
}

/// The membrane term for a material; the material is resolved once here, so the element loop
/// is compiled for the concrete model. Element work runs in parallel (OpenMP, when built with
/// it) into per-element buffers that are then summed in a fixed order: the result is
/// bit-identical for any number of threads, and a steady-state evaluation allocates nothing.
std::unique_ptr<EnergyTerm> makeMembraneTerm(std::shared_ptr<const Mesh> mesh,
                                             std::shared_ptr<const RestState> rest,
                                             const Material& material);

/// Smallest area ratio J over all triangles at x (signed for planar meshes), and which one.
double minAreaRatio(const Mesh& mesh, const RestState& rest, const VectorX& x,
                    Index* where = nullptr);

}  // namespace fem_cloth
