// The vertical alignment between the two cameras: the offset fitted from a pair's matches, the
// rows moved by it, and the stereo stage matched through it.

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>

#include <gtest/gtest.h>

#include "dco/core/synthetic_scene.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"
#include "dco/pipeline/stereo/vertical_alignment.hpp"
#include "support/good_matches.hpp"

namespace dco::stereo {
namespace {

using dco::testing::good_matches;

TEST(ShiftRows, MovesTheImageUpByTheOffsetAndRepeatsTheLastRows) {
  Image<std::uint8_t> right(3, 4), out;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 3; ++x) right.view().at(x, y) = static_cast<std::uint8_t>(10 * y + x);
  shift_rows(right.cview(), 1.0, out);  // out(y) = right(y + 1)
  EXPECT_EQ(out.view().at(2, 0), 12);
  EXPECT_EQ(out.view().at(0, 2), 30);
  EXPECT_EQ(out.view().at(0, 3), 30);    // beyond the last row: the last row
  shift_rows(right.cview(), -0.5, out);  // halfway between y - 1 and y
  EXPECT_EQ(out.view().at(0, 0), 0);     // the first row repeated
  EXPECT_EQ(out.view().at(1, 2), 16);    // (11 + 21) / 2
  EXPECT_EQ(out.view().at(0, 3), 25);
}

struct MovedPair {
  synthetic::StereoSample sample;
  Image<std::uint8_t> moved;  // the right view with its scene `offset` rows lower
};

MovedPair moved_pair(double offset, int width = 480, int height = 270) {
  MovedPair p;
  synthetic::SceneRenderer(synthetic::preset("boxes", width, height)).render(2, p.sample);
  shift_rows(p.sample.right.cview(), -offset, p.moved);
  return p;
}

TEST(FitVerticalOffset, FindsTheRowsBetweenTheCamerasFromTheMatches) {
  const MovedPair p = moved_pair(1.25);
  const ExposureMap same_levels;
  double offset = 0;
  ASSERT_TRUE(fit_vertical_offset(p.sample.left.cview(), p.moved.cview(),
                                  p.sample.disparity.cview(), same_levels, true, offset));
  EXPECT_NEAR(offset, 1.25, 0.1);
  // From near the answer, the steps alone get there too.
  offset = 1.0;
  ASSERT_TRUE(fit_vertical_offset(p.sample.left.cview(), p.moved.cview(),
                                  p.sample.disparity.cview(), same_levels, false, offset));
  EXPECT_NEAR(offset, 1.25, 0.1);
  // An aligned pair: no offset.
  ASSERT_TRUE(fit_vertical_offset(p.sample.left.cview(), p.sample.right.cview(),
                                  p.sample.disparity.cview(), same_levels, true, offset));
  EXPECT_NEAR(offset, 0.0, 0.1);
}

TEST(FitVerticalOffset, NoMatchesLeaveTheOffset) {
  const MovedPair p = moved_pair(1.0);
  Image<float> none(p.moved.width(), p.moved.height());
  none.fill(std::numeric_limits<float>::infinity());
  double offset = 0.5;
  EXPECT_FALSE(fit_vertical_offset(p.sample.left.cview(), p.moved.cview(), none.cview(),
                                   ExposureMap{}, true, offset));
  EXPECT_FALSE(fit_vertical_offset(p.sample.left.cview(), p.moved.cview(), none.cview(),
                                   ExposureMap{}, false, offset));
  EXPECT_DOUBLE_EQ(offset, 0.5);
}

TEST(CameraAlignmentMatcher, ARowAndAHalfBetweenTheCamerasCostsFewMatches) {
  const MovedPair p = moved_pair(1.5);
  StereoParams params;
  params.max_disparity = synthetic::covering_max_disparity(synthetic::preset("boxes", 480, 270));
  params.vertical_alignment = false;
  const auto plain = make_stereo_matcher({}, params);
  params.vertical_alignment = true;
  const auto aligned = make_stereo_matcher({}, params);
  Image<float> reference, without, with;
  plain->compute(p.sample.left.cview(), p.sample.right.cview(), reference);
  plain->reset();
  plain->compute(p.sample.left.cview(), p.moved.cview(), without);
  aligned->compute(p.sample.left.cview(), p.moved.cview(), with);
  const int ref = good_matches(reference, p.sample.disparity);
  const int off = good_matches(without, p.sample.disparity);
  const int on = good_matches(with, p.sample.disparity);
  std::printf(
      "good matches: aligned cameras %d, 1.5 rows apart: %d without the alignment, %d "
      "with it\n",
      ref, off, on);
  EXPECT_LT(off, 0.8 * ref);
  EXPECT_GT(on, 0.95 * ref);
}

}  // namespace
}  // namespace dco::stereo
