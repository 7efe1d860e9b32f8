#include "dco/tools/gt_alignment.hpp"

#include <cmath>
#include <cstdint>
#include <limits>

#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "dco/tools/metrics.hpp"

namespace dco::tools {
namespace {

constexpr double kDisparity = 6.4;

// A smooth texture seen by both cameras: left(x) = texture(x), right(x) = texture(x + d), so
// right(x - d) = left(x) with d = kDisparity everywhere, sub-pixel part included.
double texture(double u, int y) {
  return 128 + 60 * std::sin(0.9 * u + 0.37 * y) + 40 * std::sin(2.3 * u + 1.1 * y);
}

struct Pair {
  Image<std::uint8_t> left{64, 24}, right{64, 24};
};

Pair textured_pair() {
  Pair p;
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 64; ++x) {
      p.left.at(x, y) = static_cast<std::uint8_t>(std::lround(texture(x, y)));
      p.right.at(x, y) = static_cast<std::uint8_t>(std::lround(texture(x + kDisparity, y)));
    }
  return p;
}

Image<float> constant_gt(float value) {
  Image<float> gt(64, 24);
  gt.fill(value);
  return gt;
}

TEST(GtAlignment, FindsTheOffsetOfAGroundTruthThatIsOffItsImages) {
  const Pair p = textured_pair();
  const GtAlignment exact =
      photometric_gt_alignment(p.left.view(), p.right.view(), constant_gt(kDisparity).view());
  EXPECT_NEAR(exact.offset_px, 0.0, 0.051);
  EXPECT_GT(exact.pixels, 24 * 30);
  EXPECT_LE(exact.error_at_offset, exact.error_at_zero);

  // A GT 0.7 px too large: the images agree at GT - 0.7.
  const GtAlignment off = photometric_gt_alignment(p.left.view(), p.right.view(),
                                                   constant_gt(kDisparity + 0.7f).view());
  EXPECT_NEAR(off.offset_px, -0.7, 0.101);
  EXPECT_LT(off.error_at_offset, 0.5 * off.error_at_zero);
  EXPECT_NEAR(off.error_at_offset, exact.error_at_zero, 1.0);

  // Beyond the searched range the best offset is the range's end.
  const GtAlignment far = photometric_gt_alignment(p.left.view(), p.right.view(),
                                                   constant_gt(kDisparity - 1.5f).view(), 1.0);
  EXPECT_NEAR(far.offset_px, 1.0, 1e-9);
}

TEST(GtAlignment, UnknownGroundTruthAndFlatPixelsAreLeftOut) {
  const Pair p = textured_pair();
  Image<float> gt = constant_gt(kDisparity + 0.5f);
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 64; ++x) gt.at(x, y) = std::numeric_limits<float>::infinity();
  const GtAlignment half = photometric_gt_alignment(p.left.view(), p.right.view(), gt.view());
  EXPECT_NEAR(half.offset_px, -0.5, 0.101);
  const GtAlignment all = photometric_gt_alignment(p.left.view(), p.right.view(),
                                                   constant_gt(kDisparity + 0.5f).view());
  EXPECT_LT(half.pixels, all.pixels);

  Image<std::uint8_t> flat(64, 24);
  flat.fill(100);
  EXPECT_THROW(photometric_gt_alignment(flat.view(), flat.view(), gt.view()), Error);
}

TEST(GtAlignment, BadInputIsAnError) {
  const Pair p = textured_pair();
  const Image<float> gt = constant_gt(kDisparity);
  const Image<float> small(32, 24);
  EXPECT_THROW(photometric_gt_alignment(p.left.view(), p.right.view(), small.view()), Error);
  const Image<std::uint8_t> colour(64, 24, 3);
  EXPECT_THROW(photometric_gt_alignment(colour.view(), p.right.view(), gt.view()), Error);
  EXPECT_THROW(photometric_gt_alignment(p.left.view(), p.right.view(), gt.view(), 2.0, 0.0), Error);
  EXPECT_THROW(photometric_gt_alignment(p.left.view(), p.right.view(), gt.view(), -1.0), Error);
}

TEST(GtAlignment, ShiftedGroundTruthMovesOnlyKnownDisparities) {
  Image<float> gt(3, 1);
  gt.at(0, 0) = 10.0f;
  gt.at(1, 0) = std::numeric_limits<float>::infinity();
  gt.at(2, 0) = 0.3f;
  const Image<float> moved = shifted_ground_truth(gt.view(), -0.5);
  EXPECT_FLOAT_EQ(moved.at(0, 0), 9.5f);
  EXPECT_TRUE(std::isinf(moved.at(1, 0)));
  EXPECT_FALSE(is_valid_disparity(moved.at(2, 0)));  // pushed to 0 or below: unknown
}

}  // namespace
}  // namespace dco::tools
