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
  // What it found is what a field engineer reads in dcod's log and DCO_STATS.
  // The first round's matches, made 1.5 rows apart, gave an exposure map too (1.027 v - 3.2 as
  // the cameras' levels agree); once the offset moved it is judged afresh against no map.
  const CameraCorrection found = aligned->last_correction();
  std::printf("found: %s\n", describe(found).c_str());
  EXPECT_NEAR(found.row_offset, 1.5, 0.15);
  EXPECT_TRUE(found.same_levels());
  EXPECT_EQ(plain->last_correction().row_offset, 0.0);
}

TEST(CameraAlignmentMatcher, FindsTheRowsOfARenderedPairAndFollowsThemThroughASequence) {
  // The right camera rendered 0.75 row lower: no interpolation in the test's images.
  synthetic::SceneConfig config = synthetic::preset("hand", 480, 270);
  const synthetic::SceneRenderer met(config);
  config.right_rows = 0.75;
  const synthetic::SceneRenderer scene(config);
  StereoParams params;
  params.max_disparity = synthetic::covering_max_disparity(config);
  const auto aligned = make_stereo_matcher({}, params);
  params.vertical_alignment = false;
  const auto plain = make_stereo_matcher({}, params), reference = make_stereo_matcher({}, params);
  synthetic::StereoSample s, r;
  Image<float> with, without, rows_met;
  int on = 0, off = 0, ref = 0;
  for (int i = 0; i < 5; ++i) {
    scene.render(i, s);
    met.render(i, r);
    aligned->compute(s.left.cview(), s.right.cview(), with);
    plain->compute(s.left.cview(), s.right.cview(), without);
    reference->compute(r.left.cview(), r.right.cview(), rows_met);
    on = good_matches(with, s.disparity);
    off = good_matches(without, s.disparity);
    ref = good_matches(rows_met, r.disparity);
    EXPECT_NEAR(aligned->last_correction().row_offset, 0.75, 0.15) << "frame " << i;
    EXPECT_GT(on, 1.1 * off) << "frame " << i;
    EXPECT_GT(on, 0.97 * ref) << "frame " << i;
  }
  std::printf("frame 4: %s; good matches %d with the alignment, %d without, %d rows met\n",
              describe(aligned->last_correction()).c_str(), on, off, ref);
}

TEST(CameraCorrection, ReadsAsALogLine) {
  CameraCorrection c;
  EXPECT_TRUE(c.identity());
  EXPECT_EQ(describe(c), "right camera as the left");
  c.levels.count = 3;  // a colour camera with equal cameras
  EXPECT_TRUE(c.identity());
  c.levels.count = 1;
  c.levels.channels[0] = {0.9756, 0.14};
  c.row_offset = 0.3125;
  EXPECT_FALSE(c.identity());
  EXPECT_EQ(describe(c), "right camera levels 0.976 v + 0.1, rows +0.31");
  c.levels.count = 3;
  c.levels.channels[1] = {1.02, -2.0};
  c.levels.channels[2] = {1.0, 0.0};
  c.row_offset = -1.0;
  EXPECT_EQ(describe(c),
            "right camera levels B 0.976 v + 0.1, G 1.020 v - 2.0, R 1.000 v + 0.0, rows -1.00");
  c = CameraCorrection{};
  c.levels.count = 3;
  c.row_offset = 0.25;  // rows apart, levels alike
  EXPECT_FALSE(c.identity());
  EXPECT_EQ(describe(c), "right camera rows +0.25");
  c.row_offset = 0;
  c.levels.channels[0].offset = 2;
  EXPECT_EQ(describe(c), "right camera levels B 1.000 v + 2.0, G 1.000 v + 0.0, R 1.000 v + 0.0");
}

}  // namespace
}  // namespace dco::stereo
