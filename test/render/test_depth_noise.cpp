// Depth noise: its statistics against sigma(z) = a + b z^2, the dropout rate, reproducibility
// from the seed and the frame, NaN pixels left alone.
#include <gtest/gtest.h>

#include <cmath>

#include "fem_cloth/render/depth_noise.h"

using namespace fem_cloth;

TEST(DepthNoise, AxialNoiseHasTheModelsStandardDeviation) {
  DepthNoise noise;
  noise.a = 0.001;
  noise.b = 0.002;
  noise.seed = 7;
  // At z = 2 m: sigma = 0.001 + 0.002 * 4 = 0.009 m.
  const double z = 2.0, sigma = 0.009;
  const std::size_t n = 200000;
  std::vector<float> depth(n, static_cast<float>(z));
  applyDepthNoise(depth, noise, 0);
  double sum = 0.0, sq = 0.0;
  for (float d : depth) {
    ASSERT_FALSE(std::isnan(d));
    sum += d;
    sq += (d - z) * (d - z);
  }
  const double mean = sum / n, rms = std::sqrt(sq / n);
  // Standard errors: sigma / sqrt(n) = 2e-5 for the mean, sigma / sqrt(2 n) = 1.4e-5 for the
  // standard deviation; allow 5 of them (and float rounding of 2 m, 1.2e-7).
  EXPECT_NEAR(mean, z, 5 * sigma / std::sqrt(n));
  EXPECT_NEAR(rms, sigma, 5 * sigma / std::sqrt(2.0 * n));
  // Gaussian: about 31.7 % beyond one sigma (binomial standard error 0.1 %).
  std::size_t beyond = 0;
  for (float d : depth) beyond += std::abs(d - z) > sigma ? 1 : 0;
  EXPECT_NEAR(static_cast<double>(beyond) / n, 0.3173, 0.005);
}

TEST(DepthNoise, DropoutLosesTheGivenFractionAndKeepsTheRestExact) {
  DepthNoise noise;
  noise.dropout = 0.2;
  const std::size_t n = 100000;
  std::vector<float> depth(n, 1.5f);
  depth[10] = std::numeric_limits<float>::quiet_NaN();
  applyDepthNoise(depth, noise, 3);
  std::size_t lost = 0;
  for (float d : depth) {
    if (std::isnan(d)) {
      ++lost;
    } else {
      EXPECT_EQ(d, 1.5f) << "no axial noise configured";
    }
  }
  // 0.2 of the n - 1 valid pixels, plus the one that was NaN; binomial sd 126: allow 5 of them.
  EXPECT_NEAR(static_cast<double>(lost), 0.2 * (n - 1) + 1, 5 * std::sqrt(n * 0.2 * 0.8));
}

TEST(DepthNoise, TheSameSeedAndFrameGiveTheSameImage) {
  DepthNoise noise;
  noise.a = 0.01;
  noise.dropout = 0.1;
  noise.seed = 42;
  const std::vector<float> clean(1000, 1.0f);
  std::vector<float> a = clean, b = clean, c = clean, d = clean;
  applyDepthNoise(a, noise, 5);
  applyDepthNoise(b, noise, 5);
  applyDepthNoise(c, noise, 6);
  noise.seed = 43;
  applyDepthNoise(d, noise, 5);
  int sameAB = 0, sameAC = 0, sameAD = 0;
  for (std::size_t k = 0; k < clean.size(); ++k) {
    const auto same = [](float x, float y) { return (std::isnan(x) && std::isnan(y)) || x == y; };
    sameAB += same(a[k], b[k]);
    sameAC += same(a[k], c[k]);
    sameAD += same(a[k], d[k]);
  }
  EXPECT_EQ(sameAB, 1000);
  EXPECT_LT(sameAC, 100) << "another frame draws other noise";
  EXPECT_LT(sameAD, 100) << "another seed draws other noise";
}

TEST(DepthNoise, ValidatesItsSettings) {
  DepthNoise noise;
  EXPECT_FALSE(noise.enabled());
  EXPECT_TRUE(noise.validate());
  noise.dropout = 1.5;
  EXPECT_FALSE(noise.validate());
  noise.dropout = 0.0;
  noise.a = -1e-3;
  EXPECT_FALSE(noise.validate());
  noise.a = 0.0;
  noise.b = std::nan("");
  EXPECT_FALSE(noise.validate());
}
