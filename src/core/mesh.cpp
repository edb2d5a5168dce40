#include "fem_cloth/core/mesh.h"

#include <algorithm>
#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <set>
#include <sstream>

#include "fem_cloth/core/text_file.h"

namespace fem_cloth {

std::vector<std::array<Index, 2>> uniqueEdges(const std::vector<Triangle>& triangles) {
  std::vector<std::array<Index, 2>> edges;
  edges.reserve(triangles.size() * 3);
  for (const Triangle& t : triangles) {
    for (int k = 0; k < 3; ++k) {
      Index a = t[k], b = t[(k + 1) % 3];
      if (a > b) std::swap(a, b);
      edges.push_back({a, b});
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  return edges;
}

Expected<Mesh> makeGrid(const GridSpec& spec) {
  if (spec.rows < 2 || spec.cols < 2) {
    return Error{"grid needs at least 2 x 2 vertices, got rows = " + std::to_string(spec.rows) +
                 ", cols = " + std::to_string(spec.cols)};
  }
  if (!(spec.width > 0.0) || !(spec.height > 0.0) || !std::isfinite(spec.width) ||
      !std::isfinite(spec.height)) {
    return Error{"grid width and height must be positive and finite (m)"};
  }
  if (spec.dim != 2 && spec.dim != 3) {
    return Error{"grid dim must be 2 or 3, got " + std::to_string(spec.dim)};
  }
  for (double o : spec.origin) {
    if (!std::isfinite(o)) return Error{"grid origin must be finite"};
  }
  Mesh mesh;
  mesh.dim = spec.dim;
  const Index n = spec.rows * spec.cols;
  mesh.restPositions.resize(static_cast<Eigen::Index>(spec.dim) * n);
  const double du = spec.width / (spec.cols - 1);
  const double dv = spec.height / (spec.rows - 1);
  for (int r = 0; r < spec.rows; ++r) {
    for (int c = 0; c < spec.cols; ++c) {
      const Index i = r * spec.cols + c;
      const double u = c * du, v = r * dv;
      if (spec.dim == 2) {
        mesh.restPositions[2 * i] = spec.origin[0] + u;
        mesh.restPositions[2 * i + 1] = spec.origin[1] + v;
      } else {
        double p[3] = {spec.origin[0], spec.origin[1], spec.origin[2]};
        switch (spec.plane) {
          case GridPlane::XY: p[0] += u; p[1] += v; break;
          case GridPlane::XZ: p[0] += u; p[2] += v; break;
          case GridPlane::YZ: p[1] += u; p[2] += v; break;
        }
        for (int k = 0; k < 3; ++k) mesh.restPositions[3 * i + k] = p[k];
      }
    }
  }
  mesh.triangles.reserve(2 * static_cast<std::size_t>(spec.rows - 1) * (spec.cols - 1));
  for (int r = 0; r + 1 < spec.rows; ++r) {
    for (int c = 0; c + 1 < spec.cols; ++c) {
      const Index v00 = r * spec.cols + c, v01 = v00 + 1;
      const Index v10 = v00 + spec.cols, v11 = v10 + 1;
      // Counter-clockwise in the (u, v) parameter plane; the diagonal alternates.
      if ((r + c) % 2 == 0) {
        mesh.triangles.push_back({v00, v01, v11});
        mesh.triangles.push_back({v00, v11, v10});
      } else {
        mesh.triangles.push_back({v00, v01, v10});
        mesh.triangles.push_back({v01, v11, v10});
      }
    }
  }
  return mesh;
}

namespace {

// Parses one OBJ face corner "i", "i/t", "i//n" or "i/t/n" into a zero-based vertex index.
bool parseCorner(const std::string& token, Index numVertices, Index* out, std::string* why) {
  const std::string head = token.substr(0, token.find('/'));
  char* end = nullptr;
  const long value = std::strtol(head.c_str(), &end, 10);
  if (head.empty() || end == nullptr || *end != '\0') {
    *why = "'" + token + "' is not a vertex index";
    return false;
  }
  if (value == 0) {
    *why = "vertex index 0 (OBJ indices start at 1)";
    return false;
  }
  const long zeroBased = value > 0 ? value - 1 : numVertices + value;
  if (zeroBased < 0 || zeroBased >= numVertices) {
    *why = "vertex index " + std::to_string(value) + " out of range (" +
           std::to_string(numVertices) + " vertices defined so far)";
    return false;
  }
  *out = static_cast<Index>(zeroBased);
  return true;
}

}  // namespace

Expected<Mesh> parseObj(const std::string& text, int dim, const std::string& sourceName) {
  if (dim != 2 && dim != 3) return Error{sourceName + ": dim must be 2 or 3"};
  std::istringstream in(text);
  std::string line;
  std::vector<double> coords;
  Mesh mesh;
  mesh.dim = dim;
  int lineNo = 0;
  while (std::getline(in, line)) {
    ++lineNo;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ls(line);
    std::string tag;
    if (!(ls >> tag)) continue;
    const std::string where = sourceName + ":" + std::to_string(lineNo) + ": ";
    if (tag == "v") {
      double p[3] = {0.0, 0.0, 0.0};
      for (int k = 0; k < 3; ++k) {
        std::string token;
        if (!(ls >> token)) {
          return Error{where + "vertex line needs three coordinates"};
        }
        char* end = nullptr;
        p[k] = std::strtod(token.c_str(), &end);
        if (end == nullptr || *end != '\0') {
          return Error{where + "'" + token + "' is not a number"};
        }
        if (!std::isfinite(p[k])) {
          return Error{where + "vertex " + std::to_string(coords.size() / 3 + 1) +
                       " has a non-finite coordinate"};
        }
      }
      if (coords.size() / 3 >= static_cast<std::size_t>(kMaxVertices)) {
        return Error{where + "more than " + std::to_string(kMaxVertices) + " vertices"};
      }
      coords.insert(coords.end(), p, p + 3);
    } else if (tag == "f") {
      const Index numVertices = static_cast<Index>(coords.size() / 3);
      std::vector<Index> corners;
      std::string token;
      while (ls >> token) {
        Index idx = 0;
        std::string why;
        if (!parseCorner(token, numVertices, &idx, &why)) return Error{where + why};
        corners.push_back(idx);
        // A face of k corners is split into k - 2 triangles.
        if (mesh.triangles.size() + corners.size() > static_cast<std::size_t>(kMaxTriangles) + 2) {
          return Error{where + "more than " + std::to_string(kMaxTriangles) + " triangles"};
        }
      }
      if (corners.size() < 3) {
        return Error{where + "face needs at least 3 vertices, got " +
                     std::to_string(corners.size())};
      }
      for (std::size_t k = 1; k + 1 < corners.size(); ++k) {
        mesh.triangles.push_back({corners[0], corners[k], corners[k + 1]});
      }
    }
  }
  if (coords.empty()) return Error{sourceName + ": no vertices ('v' lines) found"};
  if (mesh.triangles.empty()) return Error{sourceName + ": no faces ('f' lines) found"};
  const Index n = static_cast<Index>(coords.size() / 3);
  mesh.restPositions.resize(static_cast<Eigen::Index>(dim) * n);
  for (Index i = 0; i < n; ++i) {
    if (dim == 2 && coords[3 * i + 2] != 0.0) {
      return Error{sourceName + ": vertex " + std::to_string(i + 1) +
                   " has z != 0 but the mesh was loaded as planar (dim 2)"};
    }
    for (int k = 0; k < dim; ++k) mesh.restPositions[dim * i + k] = coords[3 * i + k];
  }
  return mesh;
}

Expected<Mesh> loadObj(const std::string& path, int dim) {
  Expected<std::string> text = readTextFile(path, kMaxObjFileBytes, "OBJ file");
  if (!text) return Error{text.error()};
  return parseObj(*text, dim, path);
}

Eigen::Vector3d vertex3(const Mesh& mesh, const VectorX& x, Index i) {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (int k = 0; k < mesh.dim; ++k) p[k] = x[mesh.dim * i + k];
  return p;
}

double triangleArea(const Mesh& mesh, const VectorX& positions, Index t, bool signedArea) {
  const Triangle& tri = mesh.triangles[t];
  const Eigen::Vector3d a = vertex3(mesh, positions, tri[0]);
  const Eigen::Vector3d e1 = vertex3(mesh, positions, tri[1]) - a;
  const Eigen::Vector3d e2 = vertex3(mesh, positions, tri[2]) - a;
  const Eigen::Vector3d n = e1.cross(e2);
  if (signedArea && mesh.dim == 2) return 0.5 * n.z();
  return 0.5 * n.norm();
}

double restBoundingBoxDiagonal(const Mesh& mesh) {
  const int d = mesh.dim;
  const VectorX& X = mesh.restPositions;
  Eigen::VectorXd lo = X.head(d), hi = X.head(d);
  for (Index i = 1; i < mesh.numVertices(); ++i) {
    lo = lo.cwiseMin(X.segment(d * i, d));
    hi = hi.cwiseMax(X.segment(d * i, d));
  }
  return (hi - lo).norm();
}

double triangleQuality(const Mesh& mesh, Index t) {
  const Triangle& tri = mesh.triangles[t];
  const Eigen::Vector3d a = vertex3(mesh, mesh.restPositions, tri[0]);
  const Eigen::Vector3d b = vertex3(mesh, mesh.restPositions, tri[1]);
  const Eigen::Vector3d c = vertex3(mesh, mesh.restPositions, tri[2]);
  const double sumSq = (b - a).squaredNorm() + (c - b).squaredNorm() + (a - c).squaredNorm();
  if (!(sumSq > 0.0)) return 0.0;
  const double area = 0.5 * (b - a).cross(c - a).norm();
  return 4.0 * std::sqrt(3.0) * area / sumSq;
}

std::string MeshValidation::errorSummary(std::size_t maxListed) const {
  std::string out;
  for (std::size_t i = 0; i < errors.size() && i < maxListed; ++i) {
    if (!out.empty()) out += "; ";
    out += errors[i];
  }
  if (errors.size() > maxListed) {
    out += "; and " + std::to_string(errors.size() - maxListed) + " more";
  }
  return out;
}

MeshValidation validateMesh(const Mesh& mesh, double minQuality) {
  MeshValidation report;
  if (mesh.dim != 2 && mesh.dim != 3) {
    report.errors.push_back("mesh dim must be 2 or 3, got " + std::to_string(mesh.dim));
    return report;
  }
  if (mesh.restPositions.size() % mesh.dim != 0) {
    report.errors.push_back("rest positions have " + std::to_string(mesh.restPositions.size()) +
                            " entries, not a multiple of dim " + std::to_string(mesh.dim));
    return report;
  }
  const Index n = mesh.numVertices();
  if (n == 0) report.errors.push_back("mesh has no vertices");
  if (mesh.triangles.empty()) report.errors.push_back("mesh has no triangles");
  for (Index i = 0; i < n; ++i) {
    for (int k = 0; k < mesh.dim; ++k) {
      if (!std::isfinite(mesh.restPositions[mesh.dim * i + k])) {
        report.errors.push_back("vertex " + std::to_string(i) + " has a non-finite coordinate");
        break;
      }
    }
  }
  std::vector<bool> used(n, false);
  std::map<std::array<Index, 3>, Index> seen;
  std::map<std::array<Index, 2>, int> edgeUse;
  for (Index t = 0; t < mesh.numTriangles(); ++t) {
    const Triangle& tri = mesh.triangles[t];
    const std::string name = "triangle " + std::to_string(t) + " (" + std::to_string(tri[0]) +
                             ", " + std::to_string(tri[1]) + ", " + std::to_string(tri[2]) + ")";
    bool inRange = true;
    for (Index v : tri) {
      if (v < 0 || v >= n) {
        report.errors.push_back(name + ": vertex index " + std::to_string(v) +
                                " out of range [0, " + std::to_string(n) + ")");
        inRange = false;
      }
    }
    if (!inRange) continue;
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) {
      report.errors.push_back(name + ": repeats a vertex");
      continue;
    }
    for (Index v : tri) used[v] = true;
    std::array<Index, 3> key = tri;
    std::sort(key.begin(), key.end());
    auto [it, inserted] = seen.emplace(key, t);
    if (!inserted) {
      report.errors.push_back(name + ": repeats triangle " + std::to_string(it->second));
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      Index a = tri[k], b = tri[(k + 1) % 3];
      if (a > b) std::swap(a, b);
      ++edgeUse[{a, b}];
    }
    const double q = triangleQuality(mesh, t);
    if (!(q >= minQuality)) {
      std::ostringstream msg;
      msg << name << ": degenerate (zero or near-zero area " << triangleArea(mesh, mesh.restPositions, t)
          << " m^2, quality " << q << " < " << minQuality << ")";
      report.errors.push_back(msg.str());
    } else if (q < 1e-2) {
      std::ostringstream msg;
      msg << name << ": poorly shaped (quality " << q
          << "); explicit steps on it need a small time step";
      report.warnings.push_back(msg.str());
    }
  }
  int nonManifold = 0;
  for (const auto& [edge, count] : edgeUse) {
    if (count > 2) {
      if (nonManifold < 5) {
        report.warnings.push_back("edge (" + std::to_string(edge[0]) + ", " +
                                  std::to_string(edge[1]) + ") is non-manifold: shared by " +
                                  std::to_string(count) + " triangles");
      }
      ++nonManifold;
    }
  }
  if (nonManifold > 5) {
    report.warnings.push_back(std::to_string(nonManifold - 5) + " more non-manifold edges");
  }
  // A vertex of no triangle gets no mass from the lumped mass matrix: the implicit steppers'
  // system is singular there and an explicit step divides by zero. Renumbering the mesh without
  // it would shift every vertex index a scene's pins and forces refer to, so it is an error.
  if (!mesh.triangles.empty()) {
    Index unused = 0;
    for (Index i = 0; i < n; ++i) {
      if (used[i]) continue;
      if (++unused <= 3) {
        report.errors.push_back("vertex " + std::to_string(i) + " (number " + std::to_string(i + 1) +
                                " in an OBJ file) belongs to no triangle, so it would have no mass; "
                                "remove it");
      }
    }
    if (unused > 3) {
      report.errors.push_back(std::to_string(unused - 3) + " more vertices belong to no triangle");
    }
  }
  return report;
}

}  // namespace fem_cloth
