// Colours of the renderer: r, g, b in [0, 1].
#pragma once

#include <Eigen/Core>

namespace fem_cloth {

using Colour = Eigen::Vector3f;

}  // namespace fem_cloth
