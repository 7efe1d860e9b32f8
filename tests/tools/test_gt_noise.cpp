#include "dco/tools/gt_noise.hpp"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "dco/tools/metrics.hpp"

namespace dco::tools {
namespace {

constexpr float kUnknown = std::numeric_limits<float>::infinity();

TEST(GtNoise, AddsZeroMeanNoiseOfTheGivenSpreadToKnownPixelsOnly) {
  Image<float> gt(200, 200);
  gt.fill(20.0f);
  gt.at(3, 4) = kUnknown;
  gt.at(5, 6) = 0.0f;
  const Image<float> noisy = noisy_ground_truth(gt.view(), 0.25, 1);
  EXPECT_EQ(noisy.at(3, 4), kUnknown);
  EXPECT_EQ(noisy.at(5, 6), 0.0f);
  double sum = 0, sum_sq = 0;
  int n = 0, changed = 0;
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 200; ++x) {
      if (!is_valid_disparity(gt.at(x, y))) continue;
      const double e = noisy.at(x, y) - 20.0;
      sum += e, sum_sq += e * e, ++n;
      changed += e != 0;
    }
  const double mean = sum / n;
  EXPECT_NEAR(mean, 0.0, 0.01);
  EXPECT_NEAR(std::sqrt(sum_sq / n - mean * mean), 0.25, 0.01);
  EXPECT_GT(changed, n - 20);  // a sample smaller than the float spacing at 20 leaves the value
}

TEST(GtNoise, TheSameSeedGivesTheSameMapAndZeroSigmaTheGroundTruth) {
  Image<float> gt(32, 16);
  gt.fill(7.5f);
  const Image<float> a = noisy_ground_truth(gt.view(), 0.5, 9);
  const Image<float> b = noisy_ground_truth(gt.view(), 0.5, 9);
  const Image<float> c = noisy_ground_truth(gt.view(), 0.5, 10);
  const Image<float> exact = noisy_ground_truth(gt.view(), 0.0, 9);
  int same_ab = 0, same_ac = 0, same_exact = 0;
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 32; ++x) {
      same_ab += a.at(x, y) == b.at(x, y);
      same_ac += a.at(x, y) == c.at(x, y);
      same_exact += exact.at(x, y) == 7.5f;
    }
  EXPECT_EQ(same_ab, 32 * 16);
  EXPECT_LT(same_ac, 4);
  EXPECT_EQ(same_exact, 32 * 16);
}

TEST(GtNoise, NoiseBelowZeroStillLeavesAPrediction) {
  Image<float> gt(64, 64);
  gt.fill(0.1f);
  const Image<float> noisy = noisy_ground_truth(gt.view(), 5.0, 3);
  int valid = 0;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) valid += is_valid_disparity(noisy.at(x, y));
  EXPECT_EQ(valid, 64 * 64);
}

TEST(GtNoise, RejectsANegativeOrNonFiniteSigma) {
  Image<float> gt(4, 4);
  gt.fill(1.0f);
  EXPECT_THROW(noisy_ground_truth(gt.view(), -0.1, 1), Error);
  EXPECT_THROW(noisy_ground_truth(gt.view(), std::nan(""), 1), Error);
  EXPECT_THROW(noisy_ground_truth(gt.view(), std::numeric_limits<double>::infinity(), 1), Error);
}

// Where a plane crosses a slanted surface the band is decided by sub-pixel errors: a matcher
// with no other error still puts band pixels on the wrong side, more of them the larger its
// noise, while bad-2 stays at 0.
TEST(GtNoise, SubPixelNoiseAloneCostsTheBandOnASlantedSurface) {
  Image<float> gt(160, 120);
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) gt.at(x, y) = 10.0f + 0.05f * static_cast<float>(y);
  const GroundTruth truth{gt, {}};
  double previous = -1;
  for (const double sigma : {0.0, 0.05, 0.2}) {
    const Image<float> noisy = noisy_ground_truth(gt.view(), sigma, 5);
    const SceneMetrics m = evaluate_disparity("slant", noisy.view(), truth);
    EXPECT_EQ(m.all.bad2, 0.0) << sigma;
    if (sigma == 0)
      EXPECT_EQ(m.band_err, 0.0);
    else
      EXPECT_GT(m.band_err, previous + 1.0) << sigma;
    previous = m.band_err;
  }
}

}  // namespace
}  // namespace dco::tools
