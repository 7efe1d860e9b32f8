// The lens fall-off shared by the two cameras: its correction table, the k fitted from a pair's
// matches, and the stereo stage matched through the correction.

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/error.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/pipeline/stereo/lens_falloff.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"
#include "support/allocation_counter.hpp"
#include "support/fall_off.hpp"
#include "support/good_matches.hpp"
#include "support/same_bytes.hpp"
#include "support/stereo_stage.hpp"

namespace dco::stereo {
namespace {

using dco::testing::fall_off;
using dco::testing::good_matches;
using dco::testing::same_bytes;

synthetic::StereoSample falling_off(const synthetic::StereoSample& s, double k) {
  synthetic::StereoSample out;
  out.left = s.left;
  out.right = s.right;
  out.disparity = s.disparity;
  fall_off(out.left, k);
  fall_off(out.right, k);
  return out;
}

TEST(FalloffCorrection, BrightensTheCornersAndLeavesTheCentre) {
  Image<std::uint8_t> image(41, 21, 3);
  for (int y = 0; y < 21; ++y)
    for (int x = 0; x < 41; ++x)
      for (int c = 0; c < 3; ++c)
        image.view().at(x, y, c) = static_cast<std::uint8_t>(100 + 50 * c);
  FalloffCorrection none;
  none.build({}, 41, 21, 3);
  EXPECT_TRUE(none.identity());
  Image<std::uint8_t> out;
  none.apply(image.cview(), out);
  EXPECT_TRUE(same_bytes(out.cview(), image.cview()));

  FalloffCorrection lens;
  lens.build({0.4}, 41, 21, 3);
  EXPECT_FALSE(lens.identity());
  lens.apply(image.cview(), out);
  EXPECT_EQ(out.cview().at(20, 10, 0), 100);                     // the centre: r = 0
  EXPECT_EQ(out.cview().at(0, 0, 0), std::lround(100 / 0.6));    // a corner: r = 1
  EXPECT_EQ(out.cview().at(40, 20, 1), std::lround(150 / 0.6));  // each channel alike
  EXPECT_EQ(out.cview().at(0, 20, 2), 255);                      // 200 / 0.6 saturates
  EXPECT_EQ(out.cview().at(20, 0, 0), std::lround(100 / (1 - 0.4 * 100.0 / 500)));  // an edge

  Image<std::uint8_t> other(40, 21, 3), grey(41, 21);
  EXPECT_THROW(lens.apply(other.cview(), out), Error);
  EXPECT_THROW(lens.apply(grey.cview(), out), Error);  // built for three channels
}

TEST(FalloffCorrection, DifferenceIsTheLargestLevelApart) {
  EXPECT_EQ(falloff_difference({}, {}), 0);
  // At a corner level 245 becomes 245 / 0.96 = 255.2, 10 apart (levels above saturate).
  EXPECT_EQ(falloff_difference({}, {0.04}), 10);
  EXPECT_EQ(falloff_difference({0.04}, {}), 10);
  EXPECT_LE(falloff_difference({}, {0.01}), 3);
}

TEST(FitLensFalloff, FindsTheFalloffBothViewsShare) {
  const synthetic::SceneRenderer scene(synthetic::preset("boxes", 480, 270));
  synthetic::StereoSample s;
  scene.render(0, s);
  double k = 7;
  ASSERT_TRUE(fit_lens_falloff(s.left.cview(), s.right.cview(), s.disparity.cview(), k));
  EXPECT_LT(k, 0.03);  // the renderer's lenses do not fall off (a k below 0 is taken as 0)
  EXPECT_GE(k, 0.0);
  for (const double truth : {0.15, 0.35}) {
    const synthetic::StereoSample dark = falling_off(s, truth);
    ASSERT_TRUE(fit_lens_falloff(dark.left.cview(), dark.right.cview(), dark.disparity.cview(), k));
    EXPECT_NEAR(k, truth, 0.03) << truth;
  }
}

// Warm indoor light leaves the blue channel a few levels deep: too little to tell a fall-off by,
// and the lens darkens it as it darkens the others, so the fit is the other channels'.
TEST(FitLensFalloff, AChannelTooDimToTellIsLeftOut) {
  const synthetic::SceneRenderer scene(synthetic::preset("boxes", 480, 270));
  synthetic::StereoSample grey;
  scene.render(0, grey);
  // Colour from the grey render: blue a twentieth of it, green as it is, red 0.8 of it.
  synthetic::StereoSample s = grey;
  for (auto [from, to] : {std::pair{&grey.left, &s.left}, std::pair{&grey.right, &s.right}}) {
    to->resize(from->width(), from->height(), 3);
    for (int y = 0; y < from->height(); ++y)
      for (int x = 0; x < from->width(); ++x) {
        const int g = from->cview().at(x, y);
        to->view().at(x, y, 0) = static_cast<std::uint8_t>(g / 20);
        to->view().at(x, y, 1) = static_cast<std::uint8_t>(g);
        to->view().at(x, y, 2) = static_cast<std::uint8_t>(std::lround(g * 0.8));
      }
  }
  for (const double truth : {0.0, 0.15, 0.35}) {
    const synthetic::StereoSample dark = falling_off(s, truth);
    double k = 7;
    ASSERT_TRUE(fit_lens_falloff(dark.left.cview(), dark.right.cview(), dark.disparity.cview(), k))
        << truth;
    EXPECT_NEAR(k, truth, 0.03) << truth;
  }
}

TEST(FitLensFalloff, AFrameThatCannotTellLeavesK) {
  const synthetic::SceneRenderer scene(synthetic::preset("boxes", 480, 270));
  synthetic::StereoSample s;
  scene.render(0, s);
  const synthetic::StereoSample dark = falling_off(s, 0.3);
  double k = 0.123;
  // Disparity 0 everywhere puts both views of a point at one r: nothing tells a fall-off.
  Image<float> zero(480, 270);
  zero.fill(0.0f);
  EXPECT_FALSE(fit_lens_falloff(dark.left.cview(), dark.right.cview(), zero.cview(), k));
  // No matches at all.
  Image<float> none(480, 270);
  none.fill(std::numeric_limits<float>::infinity());
  EXPECT_FALSE(fit_lens_falloff(dark.left.cview(), dark.right.cview(), none.cview(), k));
  // A frame too dark to tell (mean level 9): a level step is as large as the fall-off.
  synthetic::StereoSample night = dark;
  for (Image<std::uint8_t>* image : {&night.left, &night.right})
    for (int y = 0; y < image->height(); ++y)
      for (int x = 0; x < image->width(); ++x)
        image->view().at(x, y) = static_cast<std::uint8_t>(image->view().at(x, y) / 12);
  EXPECT_FALSE(fit_lens_falloff(night.left.cview(), night.right.cview(), s.disparity.cview(), k));
  EXPECT_EQ(k, 0.123);
}

using Stage = dco::testing::StereoStage;

Stage stage_for(const synthetic::SceneConfig& config, bool falloff) {
  return dco::testing::stereo_stage(config, &StereoParams::lens_falloff, falloff);
}

TEST(LensFalloffMatcher, FindsTheFalloffOnTheFirstFrame) {
  const synthetic::SceneConfig config = synthetic::preset("boxes", 480, 270);
  const synthetic::SceneRenderer scene(config);
  synthetic::StereoSample s;
  scene.render(0, s);
  constexpr double kTruth = 0.4;
  const synthetic::StereoSample dark = falling_off(s, kTruth);
  Stage reference = stage_for(config, false), plain = stage_for(config, false),
        corrected = stage_for(config, true);
  reference.matcher->compute(s.left.cview(), s.right.cview(), reference.disparity);
  plain.matcher->compute(dark.left.cview(), dark.right.cview(), plain.disparity);
  corrected.matcher->compute(dark.left.cview(), dark.right.cview(), corrected.disparity);
  const CameraCorrection found = corrected.matcher->last_correction();
  EXPECT_NEAR(found.falloff, kTruth, 0.03);
  EXPECT_EQ(plain.matcher->last_correction().falloff, 0.0);
  char k_text[32];
  std::snprintf(k_text, sizeof k_text, "lens fall-off k %+.3f", found.falloff);
  EXPECT_NE(describe(found).find(k_text), std::string::npos) << describe(found);
  EXPECT_NE(describe(found).find("right camera as the left,"), std::string::npos);
  // The rendered texture's census bits hardly notice a fall-off (tests/accuracy has the real
  // pairs that do); matched through the correction, the pair keeps its matches.
  EXPECT_GT(good_matches(corrected.disparity, s.disparity),
            0.99 * good_matches(reference.disparity, s.disparity));
  // A later frame is matched through it at once.
  scene.render(1, s);
  const synthetic::StereoSample next = falling_off(s, kTruth);
  corrected.matcher->compute(next.left.cview(), next.right.cview(), corrected.disparity);
  EXPECT_EQ(corrected.matcher->last_correction().falloff, found.falloff);
}

// The fall-off alone, without the exposure balance and the row alignment, still gets the stage
// that fits and applies it.
TEST(LensFalloffMatcher, TheFalloffAloneIsFittedToo) {
  const synthetic::SceneConfig config = synthetic::preset("boxes", 480, 270);
  const synthetic::SceneRenderer scene(config);
  synthetic::StereoSample s;
  scene.render(0, s);
  const synthetic::StereoSample dark = falling_off(s, 0.4);
  StereoParams params;
  params.max_disparity = synthetic::covering_max_disparity(config);
  params.exposure_balance = false;
  params.vertical_alignment = false;
  params.lens_falloff = true;
  const auto matcher = make_stereo_matcher({}, params);
  Image<float> disparity;
  matcher->compute(dark.left.cview(), dark.right.cview(), disparity);
  EXPECT_NEAR(matcher->last_correction().falloff, 0.4, 0.03);
}

// The correction rounds as cv::multiply(image, gain, out, 1, CV_8U) does (the CUDA pass too), and
// a warm frame allocates nothing.
TEST(FalloffCorrection, RoundsAsOpenCvAndAllocatesNothingWhenWarm) {
  Image<std::uint8_t> image(97, 61, 3);
  for (int y = 0; y < 61; ++y)
    for (int x = 0; x < 97 * 3; ++x)
      image.row(y)[x] = static_cast<std::uint8_t>((x * 7 + y * 13) % 256);
  FalloffCorrection lens;
  lens.build({0.33}, 97, 61, 3);
  Image<std::uint8_t> out;
  lens.apply(image.cview(), out);
  // The gains again, as the correction builds them: 1 / (1 - k r^2).
  cv::Mat expected;
  cv::Mat gain(61, 97, CV_32FC3);
  for (int y = 0; y < 61; ++y)
    for (int x = 0; x < 97; ++x) {
      const float g = static_cast<float>(1.0 / (1.0 - 0.33 * falloff_radius_squared(97, 61, x, y)));
      gain.at<cv::Vec3f>(y, x) = cv::Vec3f(g, g, g);
    }
  cv::multiply(as_mat(image.cview()), gain, expected, 1.0, CV_8U);
  int differ = 0;
  for (int y = 0; y < 61; ++y)
    for (int x = 0; x < 97 * 3; ++x)
      differ += out.cview().row(y)[x] != expected.ptr<std::uint8_t>(y)[x];
  EXPECT_EQ(differ, 0);
  dco::testing::start_counting_allocations();
  lens.apply(image.cview(), out);
  const auto n = dco::testing::stop_counting_allocations();
  EXPECT_EQ(n.total(), 0);
}

TEST(LensFalloffMatcher, APairWithoutFalloffKeepsItsBytes) {
  dco::testing::expect_step_keeps_the_bytes(
      &StereoParams::lens_falloff,
      [](const StereoMatcher& m) { EXPECT_EQ(m.last_correction().falloff, 0.0); });
}

TEST(LensFalloffMatcher, AResetForgetsTheFalloff) {
  const synthetic::SceneConfig config = synthetic::preset("boxes", 320, 180);
  const synthetic::SceneRenderer scene(config);
  synthetic::StereoSample s;
  scene.render(0, s);
  const synthetic::StereoSample dark = falling_off(s, 0.4);
  Stage a = stage_for(config, true), b = stage_for(config, true);
  a.matcher->compute(dark.left.cview(), dark.right.cview(), a.disparity);
  EXPECT_GT(a.matcher->last_correction().falloff, 0.2);
  a.matcher->reset();
  EXPECT_EQ(a.matcher->last_correction().falloff, 0.0);
  a.matcher->compute(s.left.cview(), s.right.cview(), a.disparity);
  b.matcher->compute(s.left.cview(), s.right.cview(), b.disparity);
  EXPECT_TRUE(same_bytes(a.disparity.cview(), b.disparity.cview()));
}

}  // namespace
}  // namespace dco::stereo
