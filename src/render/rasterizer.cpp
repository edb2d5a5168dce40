#include "fem_cloth/render/rasterizer.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace fem_cloth {

namespace {

using Point2 = Eigen::Vector2d;

// The edge function of the directed edge from -> to, e(q) = (to - from) x (q - from): positive
// when q is to the left of it in (u, v) coordinates, as e(q) = a u + b v + c. The coefficients
// come from the lexicographically smaller end point, so the two triangles sharing an edge get
// exactly opposite ones and exactly opposite values at every pixel: no pixel on a shared edge is
// lost or drawn twice to rounding.
struct Edge {
  double a = 0.0, b = 0.0, c = 0.0;
  bool owns = false;  // whether a pixel centre exactly on the edge belongs to this triangle

  Edge(const Point2& from, const Point2& to) {
    const bool swapped = to.x() < from.x() || (to.x() == from.x() && to.y() < from.y());
    const Point2& s = swapped ? to : from;
    const Point2& t = swapped ? from : to;
    const double sign = swapped ? -1.0 : 1.0;
    a = -sign * (t.y() - s.y());
    b = sign * (t.x() - s.x());
    c = sign * ((t.y() - s.y()) * s.x() - (t.x() - s.x()) * s.y());
    // The neighbour across the edge traverses it the other way, so exactly one of the two
    // owns it (for a positively oriented triangle).
    const double dv = to.y() - from.y();
    owns = dv < 0.0 || (dv == 0.0 && to.x() - from.x() > 0.0);
  }
  double at(double u, double v) const { return a * u + b * v + c; }
  bool inside(double e) const { return e > 0.0 || (e == 0.0 && owns); }
};

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
  if (Edge(s[0], s[1]).at(s[2].x(), s[2].y()) < 0.0) std::swap(o[1], o[2]);
  const Point2 &a = s[o[0]], &b = s[o[1]], &d = s[o[2]];
  // Edge k is opposite vertex k: its value at a pixel over the area is that vertex's weight.
  const std::array<Edge, 3> edges = {Edge(b, d), Edge(d, a), Edge(a, b)};
  const double area = edges[2].at(d.x(), d.y());
  if (!(area > 0.0)) return;  // seen edge-on: covers no pixel centre
  // Barycentric weight over z, per unit of edge value.
  const std::array<double, 3> wo = {w[o[0]] / area, w[o[1]] / area, w[o[2]] / area};
  const std::array<Colour, 3> co = {c[o[0]], c[o[1]], c[o[2]]};
  const int i0 = std::max(0, static_cast<int>(std::ceil(std::min({a.x(), b.x(), d.x()}))));
  const int i1 = std::min(camera_.width - 1, static_cast<int>(std::floor(std::max({a.x(), b.x(), d.x()}))));
  const int j0 = std::max(0, static_cast<int>(std::ceil(std::min({a.y(), b.y(), d.y()}))));
  const int j1 = std::min(camera_.height - 1, static_cast<int>(std::floor(std::max({a.y(), b.y(), d.y()}))));
  for (int j = j0; j <= j1; ++j) {
    // The row's span from the three edges (a pixel of margin for rounding: the exact test
    // below decides).
    double lo = i0, hi = i1;
    for (const Edge& e : edges) {
      const double r = e.b * j + e.c;
      if (e.a > 0.0) {
        lo = std::max(lo, std::ceil(-r / e.a) - 1.0);
      } else if (e.a < 0.0) {
        hi = std::min(hi, std::floor(-r / e.a) + 1.0);
      } else if (r < 0.0) {
        hi = lo - 1.0;
      }
    }
    for (int i = static_cast<int>(lo); i <= static_cast<int>(hi); ++i) {
      const double e0 = edges[0].at(i, j), e1 = edges[1].at(i, j), e2 = edges[2].at(i, j);
      if (!edges[0].inside(e0) || !edges[1].inside(e1) || !edges[2].inside(e2)) continue;
      const double l0 = e0 * wo[0], l1 = e1 * wo[1], l2 = e2 * wo[2];
      const double z = 1.0 / (l0 + l1 + l2);
      if (z > far_) continue;
      const std::size_t at = index(i, j);
      const float zf = static_cast<float>(z);
      if (zf >= depth_[at]) continue;  // false while the pixel is empty (NaN)
      depth_[at] = zf;
      const Colour colour = static_cast<float>(l0 * z) * co[0] + static_cast<float>(l1 * z) * co[1] +
                            static_cast<float>(l2 * z) * co[2];
      rgb_[3 * at] = toByte(colour.x());
      rgb_[3 * at + 1] = toByte(colour.y());
      rgb_[3 * at + 2] = toByte(colour.z());
    }
  }
}

}  // namespace fem_cloth
