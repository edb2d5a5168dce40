// Triangle meshes embedded in 2D (planar sheets, whose elements can invert) or 3D (cloth).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "fem_cloth/core/conventions.h"
#include "fem_cloth/core/expected.h"

namespace fem_cloth {

using Triangle = std::array<Index, 3>;

/// The largest mesh a scene may have: 10^7 vertices (about 2 x 10^7 triangles). Far beyond what
/// steps in useful time here, far below where Index (int) arithmetic on DOFs (3 n) overflows.
constexpr Index kMaxVertices = 10'000'000;
constexpr Index kMaxTriangles = 2 * kMaxVertices;
/// The largest OBJ file read (bytes): room for a mesh of kMaxVertices vertices.
constexpr std::uintmax_t kMaxObjFileBytes = std::uintmax_t{1} << 30;

struct Mesh {
  /// Embedding dimension: 2 (planar) or 3 (cloth).
  int dim = 3;
  /// Rest positions, flat: coordinate k of vertex i at dim*i + k (metres).
  VectorX restPositions;
  std::vector<Triangle> triangles;

  Index numVertices() const { return static_cast<Index>(restPositions.size() / dim); }
  Index numTriangles() const { return static_cast<Index>(triangles.size()); }
  Index numDofs() const { return static_cast<Index>(restPositions.size()); }
};

/// Vertex i of positions x (mesh.dim values per vertex) as a 3D point (z = 0 in 2D).
Eigen::Vector3d vertex3(const Mesh& mesh, const VectorX& x, Index i);

/// Unique undirected edges (i < j), sorted.
std::vector<std::array<Index, 2>> uniqueEdges(const std::vector<Triangle>& triangles);

/// For each vertex, the elements whose stencil (vertex list) holds it, and the vertex's place in
/// that stencil: the vertex-to-element table local solvers need (EnergyTerm::vertexDerivatives).
/// Stored as one array (CSR), in element order per vertex.
class VertexIncidence {
 public:
  struct Use {
    Index element;  ///< the element's index in the term
    int slot;       ///< the vertex's place in the element's stencil
  };
  struct Range {
    const Use* first;
    const Use* last;
    const Use* begin() const { return first; }
    const Use* end() const { return last; }
    std::size_t size() const { return static_cast<std::size_t>(last - first); }
  };

  VertexIncidence() = default;
  /// stencils[e]: the vertices of element e (any iterable of Index), each in [0, numVertices).
  template <class Stencils>
  VertexIncidence(Index numVertices, const Stencils& stencils) {
    assign(numVertices, stencils);
  }
  /// Rebuilds the table for new stencils, reusing its storage (no allocation once grown).
  template <class Stencils>
  void assign(Index numVertices, const Stencils& stencils) {
    start_.assign(static_cast<std::size_t>(numVertices) + 1, 0);
    for (const auto& stencil : stencils) {
      for (Index v : stencil) ++start_[static_cast<std::size_t>(v) + 1];
    }
    for (std::size_t i = 1; i < start_.size(); ++i) start_[i] += start_[i - 1];
    uses_.resize(static_cast<std::size_t>(start_.back()));
    next_.assign(start_.begin(), start_.end() - 1);
    Index element = 0;
    for (const auto& stencil : stencils) {
      int slot = 0;
      for (Index v : stencil) {
        uses_[static_cast<std::size_t>(next_[static_cast<std::size_t>(v)]++)] = Use{element, slot++};
      }
      ++element;
    }
  }

  /// False for a default-constructed table (nothing assigned yet), true once assigned.
  bool isBuilt() const { return !start_.empty(); }
  Index numVertices() const { return start_.empty() ? 0 : static_cast<Index>(start_.size() - 1); }
  Range uses(Index vertex) const {
    const Use* base = uses_.data();
    return {base + start_[static_cast<std::size_t>(vertex)],
            base + start_[static_cast<std::size_t>(vertex) + 1]};
  }

 private:
  std::vector<Index> start_;
  std::vector<Use> uses_;
  std::vector<Index> next_;  // scratch of assign()
};

/// The plane a grid is laid out in (3D only): its first axis runs along `cols`, its second along
/// `rows`.
enum class GridPlane { XY, XZ, YZ };

struct GridSpec {
  int rows = 2;          ///< vertices along the second axis (>= 2)
  int cols = 2;          ///< vertices along the first axis (>= 2)
  double width = 1.0;    ///< extent along the first axis (m)
  double height = 1.0;   ///< extent along the second axis (m)
  int dim = 3;           ///< 2 = planar sheet, 3 = cloth
  GridPlane plane = GridPlane::XY;
  std::array<double, 3> origin{0.0, 0.0, 0.0};  ///< position of vertex 0 (m)
};

/// A rows x cols vertex grid split into 2 (rows-1)(cols-1) triangles. The diagonal of each quad
/// alternates in a checkerboard pattern so the mesh has no preferred shear direction.
/// Vertex (r, c) has index r*cols + c.
Expected<Mesh> makeGrid(const GridSpec& spec);

/// Reads `v` and `f` lines of a Wavefront OBJ file (other lines are ignored). Faces with more
/// than three vertices are split into a fan; `f a/b/c` and negative (relative) indices are
/// accepted. dim = 2 drops the z coordinate and requires it to be zero. The file must be a regular
/// text file of at most kMaxObjFileBytes, the mesh at most kMaxVertices and kMaxTriangles.
Expected<Mesh> loadObj(const std::string& path, int dim = 3);
/// Same, from OBJ text; `sourceName` is used in error messages.
Expected<Mesh> parseObj(const std::string& text, int dim = 3, const std::string& sourceName = "obj");

struct MeshValidation {
  std::vector<std::string> errors;    ///< make the mesh unusable; each names the element
  std::vector<std::string> warnings;  ///< worth knowing (non-manifold edges, poor shapes)
  bool ok() const { return errors.empty(); }
  /// All errors joined into one message (empty if ok).
  std::string errorSummary(std::size_t maxListed = 5) const;
};

/// Shape quality of a triangle: 4 sqrt(3) area / (sum of squared edge lengths); 1 for an
/// equilateral triangle, 0 for a degenerate one. Scale invariant.
double triangleQuality(const Mesh& mesh, Index t);
/// Area of triangle t at the given flat positions (m^2, unsigned; signed for planar meshes if
/// `signedArea` is set: positive when counter-clockwise).
double triangleArea(const Mesh& mesh, const VectorX& positions, Index t, bool signedArea = false);
/// Diagonal of the axis-aligned bounding box of the rest positions (m): the size of the cloth.
double restBoundingBoxDiagonal(const Mesh& mesh);

/// Checks the mesh. Errors: dim not 2 or 3, non-finite coordinates, vertex index out of range,
/// a triangle repeating a vertex, repeated triangles, triangles whose quality is below
/// `minQuality` (zero- or near-zero area), vertices used by no triangle (they would have no
/// mass). Warnings: non-manifold edges (shared by more than two triangles).
MeshValidation validateMesh(const Mesh& mesh, double minQuality = 1e-4);

}  // namespace fem_cloth
