#include "dco/tools/occlusion_error_map.hpp"

#include <cstdint>
#include <limits>

#include <gtest/gtest.h>

#include "dco/core/error.hpp"

namespace dco::tools {
namespace {

constexpr float kUnknown = std::numeric_limits<float>::infinity();
constexpr int kW = 40, kH = 20;

// Background at 10 left of column 20, an object at 30 from it; the plane at 20 puts the
// boundary between columns 19 and 20 and the band over columns 16..23.
Image<float> step_gt() {
  Image<float> gt(kW, kH);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) gt.at(x, y) = x < 20 ? 10.0f : 30.0f;
  return gt;
}

Image<std::uint8_t> grey(std::uint8_t level) {
  Image<std::uint8_t> img(kW, kH);
  img.fill(level);
  return img;
}

::testing::AssertionResult has_color(const Image<std::uint8_t>& map, int x, int y,
                                     const std::uint8_t (&color)[3], bool full = true) {
  for (int c = 0; c < 3; ++c) {
    const int want = full ? color[c] : color[c] / 2;
    if (map.at(x, y, c) != want)
      return ::testing::AssertionFailure() << "pixel (" << x << ", " << y << ") channel " << c
                                           << " is " << int(map.at(x, y, c)) << ", not " << want;
  }
  return ::testing::AssertionSuccess();
}

TEST(OcclusionErrorMap, MarksTheHaloTheShowThroughAndMissingValuesInsideAndOutsideTheBand) {
  const Image<float> gt = step_gt();
  Image<float> pred = gt;
  for (int y = 0; y < kH; ++y) pred.at(19, y) = 30.0f;  // a one-pixel halo left of the object
  pred.at(22, 5) = 12.0f;                               // show-through inside the band
  pred.at(35, 5) = 12.0f;                               // and outside it
  pred.at(17, 8) = kUnknown;                            // no value in the band
  const Image<std::uint8_t> map =
      occlusion_error_map(grey(200).view(), pred.view(), gt.view(), 20.0);
  ASSERT_EQ(map.channels(), 3);
  ASSERT_EQ(map.width(), kW);
  using C = ErrorMapColors;
  EXPECT_TRUE(has_color(map, 19, 3, C::kFrontMatched));
  EXPECT_TRUE(has_color(map, 22, 5, C::kBehindMatched));
  EXPECT_TRUE(has_color(map, 35, 5, C::kBehindMatched, false));
  EXPECT_TRUE(has_color(map, 17, 8, C::kMissing));
  EXPECT_TRUE(has_color(map, 18, 3, C::kBandRight));
  EXPECT_TRUE(has_color(map, 23, 3, C::kBandRight));
  for (const int x : {0, 15, 24, 39}) EXPECT_EQ(map.at(x, 3, 1), 100) << x;  // the image, dimmed
}

TEST(OcclusionErrorMap, TellsFilledValuesFromMatchedOnesByTheSparseMap) {
  const Image<float> gt = step_gt();
  Image<float> pred = gt;
  Image<float> matches = gt;
  pred.at(18, 2) = pred.at(18, 3) = 25.0f;
  matches.at(18, 3) = kUnknown;  // (18, 2) matched, (18, 3) filled
  const Image<std::uint8_t> map =
      occlusion_error_map(grey(0).view(), pred.view(), gt.view(), 20.0, matches.view());
  EXPECT_TRUE(has_color(map, 18, 2, ErrorMapColors::kFrontMatched));
  EXPECT_TRUE(has_color(map, 18, 3, ErrorMapColors::kFrontFilled));
}

TEST(OcclusionErrorMap, PixelsWithoutGroundTruthShowOnlyTheImage) {
  Image<float> gt = step_gt();
  for (int x = 0; x < kW; ++x) gt.at(x, 4) = kUnknown;
  Image<float> pred = gt;
  pred.fill(30.0f);
  Image<std::uint8_t> color(kW, kH, 3);
  color.fill(0);
  for (int x = 0; x < kW; ++x) color.at(x, 4, 1) = 200;  // green only: grey (200 * 150) >> 8
  const Image<std::uint8_t> map = occlusion_error_map(color.view(), pred.view(), gt.view(), 20.0);
  for (int c = 0; c < 3; ++c) EXPECT_EQ(map.at(10, 4, c), ((200 * 150) >> 8) / 2);
  EXPECT_TRUE(has_color(map, 10, 3, ErrorMapColors::kFrontMatched, false));
}

TEST(OcclusionErrorMap, RefusesMapsThatDoNotFitTheGroundTruth) {
  const Image<float> gt = step_gt();
  const Image<float> small(kW - 1, kH);
  const Image<std::uint8_t> two_channels(kW, kH, 2);
  EXPECT_THROW(occlusion_error_map(grey(0).view(), small.view(), gt.view(), 20.0), Error);
  EXPECT_THROW(occlusion_error_map(grey(0).view(), gt.view(), gt.view(), 20.0, small.view()),
               Error);
  EXPECT_THROW(occlusion_error_map(two_channels.view(), gt.view(), gt.view(), 20.0), Error);
  EXPECT_THROW(
      occlusion_error_map(Image<std::uint8_t>(kW, kH + 1).view(), gt.view(), gt.view(), 20.0),
      Error);
}

}  // namespace
}  // namespace dco::tools
