#include "fem_cloth/render/depth_noise.h"

#include <cmath>
#include <limits>
#include <random>

namespace fem_cloth {

Status DepthNoise::validate() const {
  if (!(a >= 0.0) || !(b >= 0.0) || !std::isfinite(a) || !std::isfinite(b)) {
    return Error{"noise coefficients a and b must be finite and >= 0, got " + numberText(a) +
                 " and " + numberText(b)};
  }
  if (!(dropout >= 0.0 && dropout <= 1.0)) {
    return Error{"dropout must be a probability in [0, 1], got " + numberText(dropout)};
  }
  return Status::success();
}

void applyDepthNoise(std::vector<float>& depth, const DepthNoise& noise, std::uint64_t frame) {
  if (!noise.enabled()) return;
  std::seed_seq seq{static_cast<std::uint32_t>(noise.seed), static_cast<std::uint32_t>(noise.seed >> 32),
                    static_cast<std::uint32_t>(frame), static_cast<std::uint32_t>(frame >> 32)};
  std::mt19937_64 generator(seq);
  // Uniform in (0, 1) from the top 53 bits (never 0, so the logarithm below is finite).
  auto uniform = [&generator]() { return ((generator() >> 11) + 0.5) * (1.0 / 9007199254740992.0); };
  constexpr double kTwoPi = 6.283185307179586;
  for (float& z : depth) {
    if (std::isnan(z)) continue;
    // Three draws per valid pixel whatever the settings, so a dropped pixel does not shift the
    // noise of the pixels after it: one for dropout, two for the Gaussian (Box-Muller).
    const double lost = uniform(), u1 = uniform(), u2 = uniform();
    if (lost < noise.dropout) {
      z = std::numeric_limits<float>::quiet_NaN();
      continue;
    }
    const double gaussian = std::sqrt(-2.0 * std::log(u1)) * std::cos(kTwoPi * u2);
    z = static_cast<float>(z + noise.sigma(z) * gaussian);
  }
}

}  // namespace fem_cloth
