#include "fem_cloth/core/air.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <sstream>

namespace fem_cloth {

namespace {

// The normal and tangential parts of a relative velocity against a unit normal.
struct Split {
  double s;            // v_r . n
  Eigen::Vector3d vt;  // v_r - s n
  double t;            // |v_t|
};

Split split(const Eigen::Vector3d& vr, const Eigen::Vector3d& n) {
  Split out;
  out.s = vr.dot(n);
  out.vt = vr - out.s * n;
  out.t = out.vt.norm();
  return out;
}

}  // namespace

AirModel::AirModel(std::shared_ptr<const Mesh> mesh, AirSettings settings)
    : mesh_(std::move(mesh)), settings_(settings) {
  normal_.assign(mesh_->triangles.size(), Eigen::Vector3d::Zero());
  area_.assign(mesh_->triangles.size(), 0.0);
}

void AirModel::prepareVertexAccess() {
  if (!incidence_.isBuilt()) incidence_.assign(mesh_->numVertices(), mesh_->triangles);
}

void AirModel::lag(const VectorX& x) {
  for (std::size_t t = 0; t < mesh_->triangles.size(); ++t) {
    const Triangle& tri = mesh_->triangles[t];
    const Eigen::Vector3d a = x.segment<3>(3 * tri[0]);
    const Eigen::Vector3d cross = (x.segment<3>(3 * tri[1]) - a).cross(x.segment<3>(3 * tri[2]) - a);
    const double norm = cross.norm();
    area_[t] = 0.5 * norm;
    // A collapsed triangle has no area to catch air.
    normal_[t] = norm > 0.0 ? Eigen::Vector3d(cross / norm) : Eigen::Vector3d::Zero();
  }
}

Eigen::Vector3d AirModel::relative(const VectorX& v, Index t) const {
  const Triangle& tri = mesh_->triangles[static_cast<std::size_t>(t)];
  return (v.segment<3>(3 * tri[0]) + v.segment<3>(3 * tri[1]) + v.segment<3>(3 * tri[2])) / 3.0 -
         settings_.wind;
}

Eigen::Vector3d AirModel::triangleForce(const Eigen::Vector3d& vr, std::size_t t) const {
  const double half = 0.5 * settings_.density;
  const Eigen::Vector3d& n = normal_[t];
  const Split p = split(vr, n);
  return -half * area_[t] *
         (settings_.normalDrag * std::abs(p.s) * p.s * n + settings_.tangentialDrag * p.t * p.vt);
}

Eigen::Matrix3d AirModel::triangleCurvature(const Eigen::Vector3d& vr, std::size_t t) const {
  const Eigen::Vector3d& n = normal_[t];
  const Split p = split(vr, n);
  Eigen::Matrix3d hr = (2.0 * settings_.normalDrag * std::abs(p.s)) * n * n.transpose();
  if (p.t > 0.0) {
    hr += settings_.tangentialDrag *
          (p.t * (Eigen::Matrix3d::Identity() - n * n.transpose()) + p.vt * p.vt.transpose() / p.t);
  }
  return hr;
}

void AirModel::force(const VectorX& v, VectorX& out) const {
  out.setZero(v.size());
  for (std::size_t t = 0; t < mesh_->triangles.size(); ++t) {
    const Eigen::Vector3d f = triangleForce(relative(v, static_cast<Index>(t)), t);
    for (Index k : mesh_->triangles[t]) out.segment<3>(3 * k) += f / 3.0;
  }
}

bool AirModel::vertexDerivatives(const VectorX& x, const VectorX& xc, double gamma, Index vertex,
                                 VertexDerivatives& out) const {
  if (!incidence_.isBuilt()) return false;  // not prepared
  out = VertexDerivatives{};
  const double half = 0.5 * settings_.density;
  for (const VertexIncidence::Use& use : incidence_.uses(vertex)) {
    const auto t = static_cast<std::size_t>(use.element);
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (Index k : mesh_->triangles[t]) mean += gamma * (x.segment<3>(3 * k) - xc.segment<3>(3 * k));
    const Eigen::Vector3d vr = mean / 3.0 - settings_.wind;
    out.force += triangleForce(vr, t) / 3.0;
    // v_r is the mean of the three velocities: each vertex's block gets 1/9.
    out.hessian += triangleCurvature(vr, t) * (half * area_[t] / 9.0);
  }
  return true;
}

double AirModel::dissipation(const VectorX& v) const {
  double sum = 0.0;
  for (std::size_t t = 0; t < mesh_->triangles.size(); ++t) {
    const Split p = split(relative(v, static_cast<Index>(t)), normal_[t]);
    sum += area_[t] * (settings_.normalDrag * std::pow(std::abs(p.s), 3) +
                       settings_.tangentialDrag * p.t * p.t * p.t);
  }
  return 0.5 * settings_.density * sum / 3.0;
}

void AirModel::addHessian(const VectorX& v, double scale, SparseHessian& H) {
  const std::size_t numTriangles = mesh_->triangles.size();
  if (offsetsFor_ != &H) {
    offsets_.assign(numTriangles * 27, -1);
    std::vector<int> local;
    for (std::size_t t = 0; t < numTriangles; ++t) {
      const Triangle& tri = mesh_->triangles[t];
      H.stencilOffsets({tri[0], tri[1], tri[2]}, local);
      std::copy(local.begin(), local.end(), offsets_.begin() + static_cast<long>(27 * t));
    }
    offsetsFor_ = &H;
  }
  const double half = 0.5 * settings_.density;
  Eigen::Matrix<double, 9, 9> element;
  for (std::size_t t = 0; t < numTriangles; ++t) {
    // d^2 D / dv_r^2; v_r is the mean of the three velocities, so each pair of vertices gets 1/9.
    Eigen::Matrix3d hr = triangleCurvature(relative(v, static_cast<Index>(t)), t);
    hr *= scale * half * area_[t] / 9.0;
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) element.block<3, 3>(3 * a, 3 * b) = hr;
    }
    H.addElement<9>(element, &offsets_[27 * t]);
  }
}

double AirModel::explicitRate(const VectorX& v, const VectorX& vertexMasses) const {
  // Row sums of |d(force_a)/dv_b| <= sum over the vertex's triangles of 3 x |hr| / 9, with
  // |hr| <= 1/2 rho A (2 C_n |s| + 2 C_t |v_t|).
  std::vector<double>& rowSum = rowSum_;
  rowSum.assign(static_cast<std::size_t>(mesh_->numVertices()), 0.0);
  for (std::size_t t = 0; t < mesh_->triangles.size(); ++t) {
    const Split p = split(relative(v, static_cast<Index>(t)), normal_[t]);
    const double bound = settings_.density * area_[t] *
                         (settings_.normalDrag * std::abs(p.s) + settings_.tangentialDrag * p.t) / 3.0;
    for (Index k : mesh_->triangles[t]) rowSum[static_cast<std::size_t>(k)] += bound;
  }
  double rate = 0.0;
  for (std::size_t i = 0; i < rowSum.size(); ++i) {
    const double m = vertexMasses[static_cast<Index>(i)];
    if (m > 0.0) rate = std::max(rate, rowSum[i] / m);
  }
  return rate;
}

bool LaggedAir::begin(AirModel* air, const VectorX& external, const State& state,
                      const VectorX& vertexMasses, double h, const char* integrator,
                      StepReport& report) {
  active_ = air != nullptr;
  forces_ = &external;
  if (!active_) return true;
  air->lag(state.x);
  const double rate = air->explicitRate(state.v, vertexMasses);
  if (h * rate > 1.0) {
    std::ostringstream msg;
    msg << integrator << ": the air drag (explicit in this integrator) needs substeps of at most "
        << 1.0 / rate << " s at the present speeds, the substep is " << h << " s";
    report.ok = false;
    report.error = msg.str();
    return false;
  }
  air->force(state.v, airForce_);
  total_ = external + airForce_;
  xStart_ = state.x;
  forces_ = &total_;
  return true;
}

double LaggedAir::work(const VectorX& xEnd) const {
  return active_ ? airForce_.dot(xEnd - xStart_) : 0.0;
}

}  // namespace fem_cloth
