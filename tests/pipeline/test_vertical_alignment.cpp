// The vertical alignment between the two cameras: the offset and roll fitted from a pair's
// matches, the right image brought back by them, and the stereo stage matched through them.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <numbers>

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

TEST(FitRowAlignment, FindsTheRowsBetweenTheCamerasFromTheMatches) {
  const MovedPair p = moved_pair(1.25);
  const ExposureMap same_levels;
  RowAlignment a;
  ASSERT_TRUE(fit_row_alignment(p.sample.left.cview(), p.moved.cview(), p.sample.disparity.cview(),
                                same_levels, true, a));
  EXPECT_NEAR(a.offset, 1.25, 0.05);
  EXPECT_NEAR(a.roll, 0.0, 0.0002);  // under 0.05 rows at the side edges
  // From near the answer, the steps alone get there too.
  a = {1.0, 0.0};
  ASSERT_TRUE(fit_row_alignment(p.sample.left.cview(), p.moved.cview(), p.sample.disparity.cview(),
                                same_levels, false, a));
  EXPECT_NEAR(a.offset, 1.25, 0.1);
  // An aligned pair: no offset.
  ASSERT_TRUE(fit_row_alignment(p.sample.left.cview(), p.sample.right.cview(),
                                p.sample.disparity.cview(), same_levels, true, a));
  EXPECT_NEAR(a.offset, 0.0, 0.05);
}

TEST(FitRowAlignment, NoMatchesLeaveTheAlignment) {
  const MovedPair p = moved_pair(1.0);
  Image<float> none(p.moved.width(), p.moved.height());
  none.fill(std::numeric_limits<float>::infinity());
  RowAlignment a{0.5, 0.001};
  EXPECT_FALSE(fit_row_alignment(p.sample.left.cview(), p.moved.cview(), none.cview(),
                                 ExposureMap{}, true, a));
  EXPECT_FALSE(fit_row_alignment(p.sample.left.cview(), p.moved.cview(), none.cview(),
                                 ExposureMap{}, false, a));
  EXPECT_EQ(a, (RowAlignment{0.5, 0.001}));
}

// The right camera of a rendered pair turned by `degrees` (and its scene `offset` rows lower).
synthetic::StereoSample turned_pair(double degrees, double offset = 0.0) {
  synthetic::SceneConfig config = synthetic::preset("boxes", 480, 270);
  config.right_rows = offset;
  config.right_roll_deg = degrees;
  synthetic::StereoSample s;
  synthetic::SceneRenderer(config).render(2, s);
  return s;
}

constexpr double kDegree = std::numbers::pi / 180.0;

TEST(FitRowAlignment, FindsTheRollBetweenTheCamerasFromTheMatches) {
  // 0.3 degrees: the side edges 1.25 rows above and below the centre's, which is 0.5 lower.
  const synthetic::StereoSample s = turned_pair(0.3, 0.5);
  RowAlignment a;
  ASSERT_TRUE(fit_row_alignment(s.left.cview(), s.right.cview(), s.disparity.cview(), {}, true, a));
  EXPECT_NEAR(a.roll / kDegree, 0.3, 0.01);
  EXPECT_NEAR(a.offset, 0.5, 0.05);
  // The steps from half the roll get most of the way.
  a = {0.5, 0.15 * kDegree};
  for (int i = 0; i < 3; ++i)
    ASSERT_TRUE(
        fit_row_alignment(s.left.cview(), s.right.cview(), s.disparity.cview(), {}, false, a));
  EXPECT_NEAR(a.roll / kDegree, 0.3, 0.03);
  EXPECT_NEAR(a.offset, 0.5, 0.1);
  // Turned the other way, no offset.
  const synthetic::StereoSample q = turned_pair(-0.2);
  a = {};
  ASSERT_TRUE(fit_row_alignment(q.left.cview(), q.right.cview(), q.disparity.cview(), {}, true, a));
  EXPECT_NEAR(a.roll / kDegree, -0.2, 0.01);
  EXPECT_NEAR(a.offset, 0.0, 0.05);
}

// Offsets up to the limit either way are found: a best row on the search window's edge is
// dropped, so the window reaches a row past the limit.
TEST(FitRowAlignment, FindsOffsetsUpToTheLimit) {
  for (const double offset : {2.9, 3.0, -3.0, 3.5, -3.9}) {
    const synthetic::StereoSample s = turned_pair(0.0, offset);
    RowAlignment a;
    ASSERT_TRUE(
        fit_row_alignment(s.left.cview(), s.right.cview(), s.disparity.cview(), {}, true, a))
        << offset;
    EXPECT_NEAR(a.offset, offset, 0.05);
    EXPECT_NEAR(a.roll / kDegree, 0.0, 0.01) << offset;
  }
}

TEST(AlignRows, TurnsTheRightImageBackOntoTheLeftsRows) {
  synthetic::SceneConfig config = synthetic::preset("boxes", 480, 270);
  config.noise_sigma = 0;
  synthetic::StereoSample upright;
  synthetic::SceneRenderer(config).render(1, upright);
  config.right_roll_deg = 0.5;
  config.right_rows = 1.0;
  synthetic::StereoSample turned;
  synthetic::SceneRenderer(config).render(1, turned);
  Image<std::uint8_t> back;
  align_rows(turned.right.cview(), {1.0, 0.5 * kDegree}, back);
  // Away from the borders, the turned view brought back differs from the upright one by the
  // blur of two bilinear passes; the turned one itself, by the rows.
  double back_diff = 0, turned_diff = 0;
  int n = 0;
  for (int y = 20; y < 250; ++y)
    for (int x = 20; x < 460; ++x, ++n) {
      back_diff += std::abs(back.view().at(x, y) - upright.right.view().at(x, y));
      turned_diff += std::abs(turned.right.view().at(x, y) - upright.right.view().at(x, y));
    }
  std::printf("mean level difference to the upright view: turned %.2f, brought back %.2f\n",
              turned_diff / n, back_diff / n);
  EXPECT_LT(back_diff / n, 0.25 * turned_diff / n);
  // Without a roll it is shift_rows, byte for byte.
  Image<std::uint8_t> shifted;
  align_rows(turned.right.cview(), {0.75, 0.0}, back);
  shift_rows(turned.right.cview(), 0.75, shifted);
  for (int y = 0; y < back.height(); ++y)
    ASSERT_TRUE(
        std::equal(back.view().row(y), back.view().row(y) + back.width(), shifted.view().row(y)))
        << "row " << y;
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

// The stage with the alignment, and two without it (one for the pair, one for a reference pair
// whose rows meet), searching a scene's whole disparity range.
struct Matchers {
  std::unique_ptr<StereoMatcher> aligned, plain, reference;
};

Matchers matchers_for(const synthetic::SceneConfig& config) {
  StereoParams params;
  params.max_disparity = synthetic::covering_max_disparity(config);
  Matchers m;
  m.aligned = make_stereo_matcher({}, params);
  params.vertical_alignment = false;
  m.plain = make_stereo_matcher({}, params);
  m.reference = make_stereo_matcher({}, params);
  return m;
}

TEST(CameraAlignmentMatcher, FindsTheRowsOfARenderedPairAndFollowsThemThroughASequence) {
  // The right camera rendered 0.75 row lower: no interpolation in the test's images.
  synthetic::SceneConfig config = synthetic::preset("hand", 480, 270);
  const synthetic::SceneRenderer met(config);
  config.right_rows = 0.75;
  const synthetic::SceneRenderer scene(config);
  const auto [aligned, plain, reference] = matchers_for(config);
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

TEST(CameraAlignmentMatcher, FollowsACameraKnockedOutOfLineWithinTwoRefits) {
  const synthetic::SceneConfig config = synthetic::preset("hand", 480, 270);
  synthetic::SceneConfig knock = config;  // the right camera's scene 2 rows lower, 0.3 deg turned
  knock.right_rows = 2.0;
  knock.right_roll_deg = 0.3;
  const synthetic::SceneRenderer met(config), knocked(knock);
  const Matchers m = matchers_for(knock);
  const auto& aligned = m.aligned;
  synthetic::StereoSample s, r;
  Image<float> with, rows_met;
  // Four frames with the rows met, then the knock. The tracking steps (one per refit, every
  // fourth frame) take at most a row each and get there by the second refit after it, frame 12;
  // the exposure map that the misaligned matches gave on the way is dropped once the rows move.
  for (int i = 0; i <= 12; ++i) {
    (i < 4 ? met : knocked).render(i, s);
    aligned->compute(s.left.cview(), s.right.cview(), with);
    if (i < 4) {
      EXPECT_TRUE(aligned->last_correction().identity()) << "frame " << i;
    }
  }
  met.render(12, r);
  m.reference->compute(r.left.cview(), r.right.cview(), rows_met);
  const int on = good_matches(with, s.disparity), ref = good_matches(rows_met, r.disparity);
  const CameraCorrection found = aligned->last_correction();
  std::printf("frame 12: %s; %d good matches, %d with the rows met\n", describe(found).c_str(), on,
              ref);
  EXPECT_NEAR(found.row_offset, 2.0, 0.15);
  EXPECT_NEAR(found.roll / kDegree, 0.3, 0.03);
  EXPECT_TRUE(found.same_levels());
  EXPECT_GT(on, 0.95 * ref);
}

TEST(CameraAlignmentMatcher, ARollBetweenTheCamerasCostsFewMatches) {
  // 0.4 degrees: the side edges 1.7 rows apart from the centre's.
  synthetic::SceneConfig config = synthetic::preset("hand", 480, 270);
  const auto [aligned, plain, reference] = matchers_for(config);
  synthetic::StereoSample met;
  synthetic::SceneRenderer(config).render(3, met);
  config.right_roll_deg = 0.4;
  synthetic::StereoSample s;
  synthetic::SceneRenderer(config).render(3, s);
  Image<float> with, without, rows_met;
  aligned->compute(s.left.cview(), s.right.cview(), with);
  plain->compute(s.left.cview(), s.right.cview(), without);
  reference->compute(met.left.cview(), met.right.cview(), rows_met);
  const int on = good_matches(with, s.disparity), off = good_matches(without, s.disparity),
            ref = good_matches(rows_met, met.disparity);
  const CameraCorrection found = aligned->last_correction();
  std::printf("%s; good matches %d with the alignment, %d without, %d with the rows met\n",
              describe(found).c_str(), on, off, ref);
  EXPECT_NEAR(found.roll / kDegree, 0.4, 0.02);
  EXPECT_NEAR(found.row_offset, 0.0, 0.125);
  EXPECT_LT(off, 0.8 * ref);
  EXPECT_GT(on, 0.95 * ref);
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
  c.roll = -0.05 * kDegree;
  EXPECT_EQ(
      describe(c),
      "right camera levels B 1.000 v + 2.0, G 1.000 v + 0.0, R 1.000 v + 0.0, roll -0.050 deg");
  c = CameraCorrection{};
  c.roll = 0.125 * kDegree;  // turned, no more
  EXPECT_FALSE(c.identity());
  EXPECT_EQ(describe(c), "right camera roll +0.125 deg");
  c.row_offset = -0.5;
  EXPECT_EQ(describe(c), "right camera rows -0.50, roll +0.125 deg");
}

}  // namespace
}  // namespace dco::stereo
