// The exposure balance between the two cameras: the map fitted from a pair's matches, its table,
// and the stereo stage matched through it.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>

#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/pipeline/stereo/exposure_balance.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"
#include "support/good_matches.hpp"
#include "support/same_bytes.hpp"
#include "support/stereo_stage.hpp"

namespace dco::stereo {
namespace {

using dco::testing::good_matches;

using dco::testing::same_bytes;

std::uint8_t scaled(double v, double gain, double offset) {
  return static_cast<std::uint8_t>(std::clamp(std::lround(gain * v + offset), 0L, 255L));
}

// Stripes 12 px wide of many levels, each row's own, with a one-pixel ridge between them; the
// right view is the left moved by `d` px with each channel's levels through gain and offset, and
// the disparity map says d everywhere.
struct ShiftedPair {
  Image<std::uint8_t> left, right;
  Image<float> disparity;
};

ShiftedPair shifted_pair(int d, const double (&gain)[3], const double (&offset)[3],
                         int channels = 1, int width = 320, int height = 120) {
  ShiftedPair p;
  p.left.resize(width, height, channels);
  p.right.resize(width, height, channels);
  p.disparity.resize(width, height);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      for (int k = 0; k < channels; ++k) {
        const int stripe = x / 12 + 7 * (y / 9) + 3 * k;
        const int level = x % 12 == 0 ? 240 : 15 + (stripe * 37) % 210;
        p.left.view().at(x, y, k) = static_cast<std::uint8_t>(level);
      }
      p.disparity.view().at(x, y) = static_cast<float>(d);
    }
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int k = 0; k < channels; ++k)
        p.right.view().at(x, y, k) =
            scaled(p.left.view().at(std::min(x + d, width - 1), y, k), gain[k], offset[k]);
  return p;
}

TEST(FitExposure, FindsTheRightCamerasGainAndOffset) {
  const ShiftedPair p = shifted_pair(9, {1.15, 1, 1}, {-8, 0, 0});
  ExposureMap map;
  ASSERT_TRUE(fit_exposure(p.left.cview(), p.right.cview(), p.disparity.cview(), map));
  EXPECT_EQ(map.count, 1);
  // Right levels v are matched as (v + 8) / 1.15.
  EXPECT_NEAR(map.channels[0].gain, 1 / 1.15, 0.005);
  EXPECT_NEAR(map.channels[0].offset, 8 / 1.15, 0.5);
}

TEST(FitExposure, FitsEachColourChannelOnItsOwn) {
  const double gain[3] = {1.1, 0.9, 1.25}, offset[3] = {3, -6, 0};
  const ShiftedPair p = shifted_pair(5, gain, offset, 3);
  ExposureMap map;
  ASSERT_TRUE(fit_exposure(p.left.cview(), p.right.cview(), p.disparity.cview(), map));
  ASSERT_EQ(map.count, 3);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(map.channels[k].gain, 1 / gain[k], 0.005) << k;
    EXPECT_NEAR(map.channels[k].offset, -offset[k] / gain[k], 0.5) << k;
  }
}

// Warm indoor light leaves the blue channel a few levels deep, too little spread to fit a line
// to; the exposure that darkened the other two darkened it alike, so it takes their map rather
// than leave the whole correction undone.
TEST(FitExposure, AChannelTooDimToFitTakesTheOthersMap) {
  const double gain[3] = {1.3, 1.3, 1.3}, offset[3] = {0, 0, 0};
  ShiftedPair p = shifted_pair(5, gain, offset, 3);
  for (int y = 0; y < p.left.height(); ++y)
    for (int x = 0; x < p.left.width(); ++x) {
      p.left.view().at(x, y, 2) = static_cast<std::uint8_t>(p.left.view().at(x, y, 2) / 20);
      p.right.view().at(x, y, 2) =
          scaled(p.left.view().at(std::min(x + 5, p.left.width() - 1), y, 2), gain[2], offset[2]);
    }
  ExposureMap map;
  ASSERT_TRUE(fit_exposure(p.left.cview(), p.right.cview(), p.disparity.cview(), map));
  ASSERT_EQ(map.count, 3);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(map.channels[k].gain, 1 / 1.3, 0.01) << k;
}

TEST(FitExposure, MatchesAPixelOffAndSaturatedLevelsDoNotMoveIt) {
  // A map off by a pixel everywhere reads the ridges wrongly, and a gain of 1.4 saturates the
  // right camera above level 182: neither may pull the fit.
  ShiftedPair p = shifted_pair(6, {1.4, 1, 1}, {0, 0, 0});
  for (int y = 0; y < p.disparity.height(); ++y)
    for (int x = 0; x < p.disparity.width(); ++x) p.disparity.view().at(x, y) = 7.0f;
  ExposureMap map;
  ASSERT_TRUE(fit_exposure(p.left.cview(), p.right.cview(), p.disparity.cview(), map));
  EXPECT_NEAR(map.channels[0].gain, 1 / 1.4, 0.005);
  EXPECT_NEAR(map.channels[0].offset, 0.0, 0.5);
}

TEST(FitExposure, AFrameThatCannotTellLeavesTheMap) {
  ExposureMap map;
  map.channels[0] = {1.1, 2.0};
  const ShiftedPair p = shifted_pair(4, {1.2, 1, 1}, {0, 0, 0});
  // No match at all.
  Image<float> none(p.left.width(), p.left.height());
  none.fill(std::numeric_limits<float>::infinity());
  EXPECT_FALSE(fit_exposure(p.left.cview(), p.right.cview(), none.cview(), map));
  // Every match outside the right image.
  Image<float> outside(p.left.width(), p.left.height());
  outside.fill(1e6f);
  EXPECT_FALSE(fit_exposure(p.left.cview(), p.right.cview(), outside.cview(), map));
  // One grey level: no spread to fit a gain to.
  Image<std::uint8_t> flat(p.left.width(), p.left.height());
  flat.fill(90);
  EXPECT_FALSE(fit_exposure(flat.cview(), flat.cview(), p.disparity.cview(), map));
  EXPECT_DOUBLE_EQ(map.channels[0].gain, 1.1);
  EXPECT_DOUBLE_EQ(map.channels[0].offset, 2.0);
}

TEST(ExposureTable, MapsEachChannelThroughItsRoundedLine) {
  ExposureTable table;
  ExposureMap map;
  table.build(map);
  EXPECT_TRUE(table.identity());
  map.channels[0] = {1.0, 0.4};  // rounds to no change
  table.build(map);
  EXPECT_TRUE(table.identity());

  map.count = 3;
  map.channels = {ChannelLevels{0.5, 10}, ChannelLevels{1, 0}, ChannelLevels{2, -300}};
  table.build(map);
  EXPECT_FALSE(table.identity());
  Image<std::uint8_t> right(2, 1, 3), out;
  const std::uint8_t levels[6] = {100, 100, 100, 255, 7, 200};
  std::copy(levels, levels + 6, right.view().row(0));
  table.apply(right.cview(), out);
  const std::uint8_t* o = out.view().row(0);
  EXPECT_EQ(o[0], 60);   // 0.5 * 100 + 10
  EXPECT_EQ(o[1], 100);  // unchanged
  EXPECT_EQ(o[2], 0);    // 2 * 100 - 300, clamped
  EXPECT_EQ(o[3], 138);  // 0.5 * 255 + 10 = 137.5, rounded away from zero
  EXPECT_EQ(o[4], 7);
  EXPECT_EQ(o[5], 100);  // 2 * 200 - 300
}

TEST(ExposureTable, DifferenceIsTheLargestLevelApart) {
  ExposureMap a, b;
  EXPECT_EQ(exposure_difference(a, b), 0);
  b.channels[0] = {1.0, 3.0};
  EXPECT_EQ(exposure_difference(a, b), 3);
  EXPECT_EQ(exposure_difference(b, a), 3);
  b.channels[0] = {1.04, 0.0};  // 10 levels apart at 245 (254.8), none at 0
  EXPECT_EQ(exposure_difference(a, b), 10);
}

using Stage = dco::testing::StereoStage;

Stage stage_for(const synthetic::SceneConfig& config, bool balance) {
  return dco::testing::stereo_stage(config, &StereoParams::exposure_balance, balance);
}

TEST(ExposureBalancedMatcher, AGainBetweenTheCamerasCostsFewMatches) {
  synthetic::SceneConfig config = synthetic::preset("boxes", 480, 270);
  const synthetic::SceneRenderer equal(config);
  config.right_gain = 1.15;
  config.right_offset = 4;
  const synthetic::SceneRenderer unequal(config);
  synthetic::StereoSample same, differ;
  equal.render(0, same);
  unequal.render(0, differ);

  Stage reference = stage_for(config, false), plain = stage_for(config, false),
        balanced = stage_for(config, true);
  reference.matcher->compute(same.left.cview(), same.right.cview(), reference.disparity);
  plain.matcher->compute(differ.left.cview(), differ.right.cview(), plain.disparity);
  balanced.matcher->compute(differ.left.cview(), differ.right.cview(), balanced.disparity);
  const int ref = good_matches(reference.disparity, same.disparity);
  const int without = good_matches(plain.disparity, differ.disparity);
  const int with = good_matches(balanced.disparity, differ.disparity);
  std::printf(
      "good matches: equal cameras %d, right gain 1.15 + 4: %d without the balance, %d "
      "with it\n",
      ref, without, with);
  EXPECT_LT(without, 0.8 * ref);  // the gain costs the plain stage matches
  EXPECT_GT(with, 0.97 * ref);    // the balance wins them back on the first frame
  EXPECT_GT(balanced.matcher->last_timings().balance_ms, 0.0);
  // The map it found, for the log: right levels v matched as (v - 4) / 1.15.
  const CameraCorrection found = balanced.matcher->last_correction();
  EXPECT_NEAR(found.levels.channels[0].gain, 1 / 1.15, 0.01);
  EXPECT_NEAR(found.levels.channels[0].offset, -4 / 1.15, 1.0);
  EXPECT_EQ(found.row_offset, 0.0);
  EXPECT_TRUE(plain.matcher->last_correction().identity());

  // A later frame of the sequence is matched through the map at once.
  unequal.render(1, differ);
  plain.matcher->compute(differ.left.cview(), differ.right.cview(), plain.disparity);
  balanced.matcher->compute(differ.left.cview(), differ.right.cview(), balanced.disparity);
  equal.render(1, same);
  reference.matcher->compute(same.left.cview(), same.right.cview(), reference.disparity);
  EXPECT_GT(good_matches(balanced.disparity, differ.disparity),
            0.97 * good_matches(reference.disparity, same.disparity));
}

// Two cameras with their own auto-exposure can differ by more than twice: a right camera 2.5
// times darker or brighter than the left is balanced too, within a few frames. Darker, it wins
// back nearly every match; brighter, what it saturated is lost, but the rest comes back.
TEST(ExposureBalancedMatcher, CamerasTwoAndAHalfTimesApartAreBalanced) {
  for (const double right_gain : {0.4, 2.5}) {
    synthetic::SceneConfig config = synthetic::preset("boxes", 480, 270);
    const synthetic::SceneRenderer equal(config);
    config.right_gain = right_gain;
    const synthetic::SceneRenderer unequal(config);
    Stage reference = stage_for(config, false), plain = stage_for(config, false),
          balanced = stage_for(config, true);
    synthetic::StereoSample same, differ;
    int ref = 0, without = 0, with = 0;
    for (int frame = 0; frame < 4; ++frame) {
      equal.render(frame, same);
      unequal.render(frame, differ);
      reference.matcher->compute(same.left.cview(), same.right.cview(), reference.disparity);
      plain.matcher->compute(differ.left.cview(), differ.right.cview(), plain.disparity);
      balanced.matcher->compute(differ.left.cview(), differ.right.cview(), balanced.disparity);
      ref = good_matches(reference.disparity, same.disparity);
      without = good_matches(plain.disparity, differ.disparity);
      with = good_matches(balanced.disparity, differ.disparity);
    }
    std::printf("right gain %.1f: good matches %d equal, %d without the balance, %d with it\n",
                right_gain, ref, without, with);
    EXPECT_NEAR(balanced.matcher->last_correction().levels.channels[0].gain, 1 / right_gain,
                0.05 / right_gain)
        << right_gain;
    if (right_gain < 1)
      EXPECT_GT(with, 0.9 * ref);
    else
      EXPECT_GT(with, 1.3 * without);
  }
}

TEST(ExposureBalancedMatcher, APairThatAgreesKeepsItsBytes) {
  dco::testing::expect_step_keeps_the_bytes(&StereoParams::exposure_balance);
}

TEST(ExposureBalancedMatcher, AResetStartsTheSequenceAfresh) {
  synthetic::SceneConfig config = synthetic::preset("boxes", 320, 180);
  config.right_gain = 0.85;
  const synthetic::SceneRenderer scene(config);
  synthetic::StereoSample first, second;
  scene.render(0, first);
  scene.render(5, second);
  Stage a = stage_for(config, true), b = stage_for(config, true);
  a.matcher->compute(first.left.cview(), first.right.cview(), a.disparity);
  a.matcher->reset();
  a.matcher->compute(second.left.cview(), second.right.cview(), a.disparity);
  b.matcher->compute(second.left.cview(), second.right.cview(), b.disparity);
  EXPECT_TRUE(same_bytes(a.disparity.cview(), b.disparity.cview()));
}

TEST(ExposureBalancedMatcher, BadInputIsRefusedBeforeAnythingReadsIt) {
  const synthetic::SceneConfig config = synthetic::preset("boxes", 320, 180);
  Stage s = stage_for(config, true);
  Image<std::uint8_t> left(320, 180), right(300, 180);
  left.fill(10);
  right.fill(10);
  EXPECT_THROW(s.matcher->compute(left.cview(), right.cview(), s.disparity), Error);
}

}  // namespace
}  // namespace dco::stereo
