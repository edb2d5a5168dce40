#include "fem_cloth/render/shape_mesh.h"

#include <algorithm>

namespace fem_cloth {

ShapeMesh tessellate(const Shape& shape, double planeSide, int segments) {
  return shapeEntry(shape.type).triangulate(shape, planeSide, std::max(segments, 8));
}

}  // namespace fem_cloth
