// Depth noise and dropout of a simulated depth camera. ROS-free.
//
// Axial noise: each valid depth z gets Gaussian noise of standard deviation
//     sigma(z) = a + b z^2   (m),
// the form measured for structured-light and stereo depth cameras, whose error grows with the
// square of the distance (Khoshelham & Elberink, "Accuracy and Resolution of Kinect Depth Data",
// Sensors 2012; Nguyen, Izadi & Lovell, "Modeling Kinect Sensor Noise", 3DIMPVT 2012, fit
// sigma = 0.0012 + 0.0019 (z - 0.4)^2 m). Dropout: each valid pixel is lost (NaN) with
// probability `dropout`. Both are drawn from a generator seeded with (seed, frame): the same
// frame of a replayed run gets the same noise, on any machine (mt19937_64 is specified exactly,
// and the Gaussian comes from it by Box-Muller, not by a library's normal_distribution).
#pragma once

#include <cstdint>
#include <vector>

#include "fem_cloth/core/expected.h"

namespace fem_cloth {

struct DepthNoise {
  double a = 0.0;        ///< m
  double b = 0.0;        ///< 1/m
  double dropout = 0.0;  ///< probability in [0, 1]
  std::uint64_t seed = 0;

  bool enabled() const { return a > 0.0 || b > 0.0 || dropout > 0.0; }
  /// a, b >= 0 and finite, dropout in [0, 1].
  Status validate() const;
  double sigma(double z) const { return a + b * z * z; }
};

/// Applies the noise to every valid (non-NaN) depth of one frame; `frame` picks its draw.
void applyDepthNoise(std::vector<float>& depth, const DepthNoise& noise, std::uint64_t frame);

}  // namespace fem_cloth
