#include "fem_cloth/render/rasterizer.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace fem_cloth {

namespace {

using Point2 = Eigen::Vector2d;

// (b - a) x (q - a): positive when q is to the left of a -> b in (u, v) coordinates. Evaluated
// from the lexicographically smaller end point, so that the two triangles sharing an edge get
// exactly opposite values for every pixel: no pixel on a shared edge is lost or drawn twice to
// rounding.
double edgeValue(const Point2& a, const Point2& b, const Point2& q) {
  const bool swapped = b.x() < a.x() || (b.x() == a.x() && b.y() < a.y());
  const Point2& s = swapped ? b : a;
  const Point2& t = swapped ? a : b;
  const double e = (t.x() - s.x()) * (q.y() - s.y()) - (t.y() - s.y()) * (q.x() - s.x());
  return swapped ? -e : e;
}

// Whether a pixel centre exactly on edge a -> b of a positively oriented triangle belongs to it.
// The neighbour across the edge traverses it the other way, so exactly one of the two owns it.
bool ownsEdge(const Point2& a, const Point2& b) {
  const double dv = b.y() - a.y();
  return dv < 0.0 || (dv == 0.0 && b.x() - a.x() > 0.0);
}

std::uint8_t toByte(float c) {
  return static_cast<std::uint8_t>(std::lround(255.0f * std::clamp(c, 0.0f, 1.0f)));
}

}  // namespace

Rasterizer::Rasterizer(const CameraIntrinsics& camera, double nearRange, double farRange)
    : camera_(camera), near_(nearRange), far_(farRange) {
  const std::size_t pixels =
      static_cast<std::size_t>(camera_.width) * static_cast<std::size_t>(camera_.height);
  depth_.assign(pixels, std::numeric_limits<float>::quiet_NaN());
  rgb_.assign(3 * pixels, 0);
}

void Rasterizer::clear(const Colour& background) {
  std::fill(depth_.begin(), depth_.end(), std::numeric_limits<float>::quiet_NaN());
  const std::uint8_t r = toByte(background.x()), g = toByte(background.y()), b = toByte(background.z());
  for (std::size_t k = 0; k < rgb_.size(); k += 3) {
    rgb_[k] = r;
    rgb_[k + 1] = g;
    rgb_[k + 2] = b;
  }
}

void Rasterizer::drawTriangle(const std::array<Eigen::Vector3d, 3>& p,
                              const std::array<Colour, 3>& c) {
  int inFront = 0;
  bool beyond = true;
  for (const Eigen::Vector3d& q : p) {
    if (!q.allFinite()) return;
    inFront += q.z() >= near_ ? 1 : 0;
    beyond = beyond && q.z() > far_;
  }
  if (inFront == 0 || beyond) return;
  if (inFront == 3) {
    drawClipped(p, c);
    return;
  }
  // Sutherland-Hodgman against the plane z = near: a triangle with one or two vertices behind
  // it becomes a triangle or a quadrilateral; attributes are linear along 3D edges.
  std::array<Eigen::Vector3d, 4> poly;
  std::array<Colour, 4> col;
  int n = 0;
  for (int k = 0; k < 3; ++k) {
    const int l = (k + 1) % 3;
    const bool kIn = p[k].z() >= near_, lIn = p[l].z() >= near_;
    if (kIn) {
      poly[n] = p[k];
      col[n++] = c[k];
    }
    if (kIn != lIn) {
      const double t = (near_ - p[k].z()) / (p[l].z() - p[k].z());
      poly[n] = p[k] + t * (p[l] - p[k]);
      poly[n].z() = near_;
      col[n++] = c[k] + static_cast<float>(t) * (c[l] - c[k]);
    }
  }
  for (int k = 1; k + 1 < n; ++k) {
    drawClipped({poly[0], poly[k], poly[k + 1]}, {col[0], col[k], col[k + 1]});
  }
}

void Rasterizer::drawClipped(const std::array<Eigen::Vector3d, 3>& p,
                             const std::array<Colour, 3>& c) {
  std::array<Point2, 3> s;
  std::array<double, 3> w;  // 1 / z
  for (int k = 0; k < 3; ++k) {
    s[k] = camera_.project(p[k]);
    w[k] = 1.0 / p[k].z();
  }
  // Positive orientation (both sides are drawn): swap two vertices of a clockwise triangle.
  std::array<int, 3> o = {0, 1, 2};
  double area = edgeValue(s[0], s[1], s[2]);
  if (area < 0.0) {
    std::swap(o[1], o[2]);
    area = -area;
  }
  if (!(area > 0.0)) return;  // seen edge-on: covers no pixel centre
  const Point2 &a = s[o[0]], &b = s[o[1]], &d = s[o[2]];
  const int i0 = std::max(0, static_cast<int>(std::ceil(std::min({a.x(), b.x(), d.x()}))));
  const int i1 = std::min(camera_.width - 1, static_cast<int>(std::floor(std::max({a.x(), b.x(), d.x()}))));
  const int j0 = std::max(0, static_cast<int>(std::ceil(std::min({a.y(), b.y(), d.y()}))));
  const int j1 = std::min(camera_.height - 1, static_cast<int>(std::floor(std::max({a.y(), b.y(), d.y()}))));
  const bool own0 = ownsEdge(b, d), own1 = ownsEdge(d, a), own2 = ownsEdge(a, b);
  for (int j = j0; j <= j1; ++j) {
    for (int i = i0; i <= i1; ++i) {
      const Point2 q(i, j);
      // Barycentric weights of a, b, d: each is the edge value opposite that vertex.
      const double e0 = edgeValue(b, d, q), e1 = edgeValue(d, a, q), e2 = edgeValue(a, b, q);
      if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) continue;
      if ((e0 == 0.0 && !own0) || (e1 == 0.0 && !own1) || (e2 == 0.0 && !own2)) continue;
      const double l0 = e0 / area, l1 = e1 / area, l2 = e2 / area;
      const double inverse = l0 * w[o[0]] + l1 * w[o[1]] + l2 * w[o[2]];
      const double z = 1.0 / inverse;
      if (z > far_) continue;
      const std::size_t at = index(i, j);
      const float zf = static_cast<float>(z);
      if (zf >= depth_[at]) continue;  // false while the pixel is empty (NaN)
      depth_[at] = zf;
      const Colour colour =
          (static_cast<float>(l0 * w[o[0]] * z) * c[o[0]] + static_cast<float>(l1 * w[o[1]] * z) * c[o[1]] +
           static_cast<float>(l2 * w[o[2]] * z) * c[o[2]]);
      rgb_[3 * at] = toByte(colour.x());
      rgb_[3 * at + 1] = toByte(colour.y());
      rgb_[3 * at + 2] = toByte(colour.z());
    }
  }
}

}  // namespace fem_cloth
