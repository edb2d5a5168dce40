// Distances between the primitives of self-contact (point-triangle and edge-edge) with the
// gradient and Hessian of the squared distance, for the barrier of Li et al. 2020 (section 4).
//
// Both distances are minima over the points of the two primitives. With the four vertices
// X = [x0 x1 x2 x3] (3 x 4), the difference of the two closest points is r = X w for a weight
// vector w that is affine in the closest points' parameters beta (barycentric coordinates on the
// triangle, positions along the edges): w = w0 + U beta. Where the closest points lie inside a
// face, an edge or at a vertex (the "region", which IPC calls the distance type: point-triangle,
// point-edge, point-point, edge-edge) the free parameters are those of that feature, and
// s = |r|^2 = min over beta, so by the envelope theorem
//     ds/dx_k = 2 w_k r,
//     d2s/dx2 = 2 (w w^T) (x) I3 - F (2 E^T E)^-1 F^T,  E = X U,  F_(k, j) = 2 (U_kj r + w_k E_j),
// the second term being what the moving closest point contributes (f_xx - f_xb f_bb^-1 f_bx).
// This is exact inside each region and reproduces IPC's per-type formulas without a case for
// each type. Vertex order: point-triangle (p, t0, t1, t2), edge-edge (a0, a1, b0, b1).

#pragma once

#include <Eigen/Core>

namespace fem_cloth {

using Vector12 = Eigen::Matrix<double, 12, 1>;
using Matrix12 = Eigen::Matrix<double, 12, 12>;

struct PrimitiveDistance {
  double squared = 0.0;  ///< s = |r|^2 (m^2)
  Eigen::Vector4d weights = Eigen::Vector4d::Zero();  ///< r = sum_k w_k x_k
  Eigen::Vector3d r = Eigen::Vector3d::Zero();  ///< closest point on the first primitive minus the second's
  int freeParameters = 0;  ///< 2: face or crossing edges, 1: an edge, 0: a vertex pair
};

/// Point p against the triangle (t0, t1, t2); optionally ds/dx and d2s/dx2 (12 DOFs).
PrimitiveDistance pointTriangleDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& t0,
                                        const Eigen::Vector3d& t1, const Eigen::Vector3d& t2,
                                        Vector12* gradient = nullptr, Matrix12* hessian = nullptr);

/// Segment (a0, a1) against the segment (b0, b1).
PrimitiveDistance edgeEdgeDistance(const Eigen::Vector3d& a0, const Eigen::Vector3d& a1,
                                   const Eigen::Vector3d& b0, const Eigen::Vector3d& b1,
                                   Vector12* gradient = nullptr, Matrix12* hessian = nullptr);

/// A positive semi-definite Gauss-Newton Hessian for a barrier b(s) of the squared distance
/// (b1 = b'(s) < 0, b2 = b''(s)). As a function of the distance d, B(d) = b(d^2) has the Hessian
///     B''(d) grad d grad d^T + B'(d) Hess d,   B'' = 4 b'' s + 2 b' >= 0 (IPC's barrier), B' < 0,
/// with grad d = w (x) r/|r|. The first term is the whole curvature for a motion of one primitive
/// along the contact normal, the way the barrier pushes; the second, the curvature of the distance
/// (a tilting plane, a cylinder about an edge, a sphere about a vertex) times B' < 0, is mostly
/// negative and discarded by IPC's per-pair eigen-projection (Li et al. 2020, section 4.3) anyway. Keeping only the first term costs no
/// eigen-decomposition; in the fold scene Newton took the same number of iterations as with the
/// eigen-projection.
Matrix12 barrierGaussNewtonHessian(const PrimitiveDistance& pd, double b1, double b2);

/// c = |(a1 - a0) x (b1 - b0)|^2 (m^4) with its gradient and Hessian: what the edge-edge
/// mollifier of Li et al. 2020 (section 4.3) fades with.
double edgeCrossSquared(const Eigen::Vector3d& a0, const Eigen::Vector3d& a1,
                        const Eigen::Vector3d& b0, const Eigen::Vector3d& b1,
                        Vector12* gradient = nullptr, Matrix12* hessian = nullptr);

}  // namespace fem_cloth
