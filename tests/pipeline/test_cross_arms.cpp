#include "dco/pipeline/stereo/cross_arms.hpp"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <initializer_list>
#include <random>
#include <utility>

#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "pipeline_test_support.hpp"

namespace dco::stereo {
namespace {

int max_channel_diff(const Image<std::uint8_t>& img, int x0, int y0, int x1, int y1) {
  int d = 0;
  for (int c = 0; c < img.channels(); ++c)
    d = std::max(d, std::abs(int(img.at(x0, y0, c)) - int(img.at(x1, y1, c))));
  return d;
}

// The arm rule written out step by step, one direction (dx, dy) at a time.
int naive_arm(const Image<std::uint8_t>& img, int x, int y, int dx, int dy, const ArmRule& rule) {
  int len = 0;
  for (int i = 1; i <= rule.arm_max; ++i) {
    const int nx = x + dx * i;
    const int ny = y + dy * i;
    if (nx < 0 || ny < 0 || nx >= img.width() || ny >= img.height()) break;
    const int to_anchor = max_channel_diff(img, nx, ny, x, y);
    const int to_prev = max_channel_diff(img, nx, ny, nx - dx, ny - dy);
    if (to_anchor >= rule.tau1 || to_prev >= rule.tau1) break;
    if (i > rule.arm_short && to_anchor >= rule.tau2) break;
    len = i;
  }
  return len;
}

CrossArms arms_of(const Image<std::uint8_t>& img, const ArmRule& rule) {
  CrossArms arms;
  compute_cross_arms(img.view(), rule, arms);
  EXPECT_EQ(arms.width(), img.width());
  EXPECT_EQ(arms.height(), img.height());
  return arms;
}

// One row whose pixels are given; the anchor is pixel 0, so its right arm is what is tested.
Image<std::uint8_t> row_image(std::initializer_list<int> values) {
  Image<std::uint8_t> img(static_cast<int>(values.size()), 1);
  int x = 0;
  for (int v : values) img.at(x++, 0) = static_cast<std::uint8_t>(v);
  return img;
}

TEST(CrossArms, StepImageArmsStopAtTheEdge) {
  // Columns 0..59 are 50, 60..99 are 200; 10 rows.
  Image<std::uint8_t> img(100, 10);
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 100; ++x) img.at(x, y) = x < 60 ? 50 : 200;
  const ArmRule rule;  // arm_max 34
  const CrossArms arms = arms_of(img, rule);
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 100; ++x) {
      const int left_edge = x < 60 ? 0 : 60;
      const int right_edge = x < 60 ? 59 : 99;
      ASSERT_EQ(arms.left.at(x, y), std::min(x - left_edge, rule.arm_max)) << x << "," << y;
      ASSERT_EQ(arms.right.at(x, y), std::min(right_edge - x, rule.arm_max)) << x << "," << y;
      ASSERT_EQ(arms.up.at(x, y), y);  // flat columns: the image border bounds them
      ASSERT_EQ(arms.down.at(x, y), 9 - y);
    }
  EXPECT_EQ(arms.right.at(59, 0), 0);
  EXPECT_EQ(arms.left.at(60, 0), 0);
  EXPECT_EQ(arms.right.at(58, 0), 1);
}

TEST(CrossArms, ArmMaxAndImageBordersBoundFlatImages) {
  Image<std::uint8_t> img(80, 50);
  img.fill(128);
  ArmRule rule;
  rule.arm_max = 12;
  rule.arm_short = 5;
  const CrossArms arms = arms_of(img, rule);
  for (int y = 0; y < 50; ++y)
    for (int x = 0; x < 80; ++x) {
      ASSERT_EQ(arms.left.at(x, y), std::min(x, 12));
      ASSERT_EQ(arms.right.at(x, y), std::min(79 - x, 12));
      ASSERT_EQ(arms.up.at(x, y), std::min(y, 12));
      ASSERT_EQ(arms.down.at(x, y), std::min(49 - y, 12));
    }
  rule.arm_max = 0;
  const CrossArms none = arms_of(img, rule);
  EXPECT_EQ(
      none.left.at(40, 25) + none.right.at(40, 25) + none.up.at(40, 25) + none.down.at(40, 25), 0);
}

TEST(CrossArms, Tau1BoundsTheDifferenceToTheAnchor) {
  ArmRule rule;
  rule.arm_short = 30;
  // Slope 1: pixel i differs from the anchor by i; tau1 = 20 stops the arm at i = 20.
  Image<std::uint8_t> ramp(40, 1);
  for (int x = 0; x < 40; ++x) ramp.at(x, 0) = static_cast<std::uint8_t>(100 + x);
  EXPECT_EQ(arms_of(ramp, rule).right.at(0, 0), 19);
  // Past arm_short = 17 the difference must stay below tau2 = 6: the same ramp stops at 18.
  rule.arm_short = 17;
  EXPECT_EQ(arms_of(ramp, rule).right.at(0, 0), 17);
  rule.arm_short = 0;  // tau2 everywhere
  EXPECT_EQ(arms_of(ramp, rule).right.at(0, 0), 5);
}

TEST(CrossArms, Tau2AppliesOnlyBeyondArmShort) {
  ArmRule rule;
  rule.arm_short = 4;
  // Anchor 100, then 110 (diff 10: fine within arm_short, too much beyond it).
  EXPECT_EQ(arms_of(row_image({100, 110, 110, 110, 110, 110, 110, 110}), rule).right.at(0, 0), 4);
  // Beyond arm_short a difference of 5 (< tau2) is still fine, 6 is not.
  EXPECT_EQ(arms_of(row_image({100, 110, 110, 110, 110, 105, 105, 106, 105}), rule).right.at(0, 0),
            6);
  // The same within arm_short only needs tau1.
  rule.arm_short = 10;
  EXPECT_EQ(arms_of(row_image({100, 110, 110, 110, 110, 105, 105, 106, 105}), rule).right.at(0, 0),
            8);
}

TEST(CrossArms, ConsecutivePixelsMustStayWithinTau1) {
  const ArmRule rule;
  // 115 is 15 from the anchor; 95 is 5 from the anchor but 20 from 115: the arm stops there.
  EXPECT_EQ(arms_of(row_image({100, 115, 95, 100}), rule).right.at(0, 0), 1);
  // 19 from the previous pixel is fine.
  EXPECT_EQ(arms_of(row_image({100, 115, 96, 100}), rule).right.at(0, 0), 3);
}

TEST(CrossArms, ColourRuleUsesTheLargestChannelDifference) {
  const ArmRule rule;
  Image<std::uint8_t> img(4, 1, 3);
  const int px[4][3] = {{100, 100, 100}, {119, 81, 119}, {100, 100, 120}, {100, 100, 100}};
  for (int x = 0; x < 4; ++x)
    for (int c = 0; c < 3; ++c) img.at(x, 0, c) = static_cast<std::uint8_t>(px[x][c]);
  const CrossArms arms = arms_of(img, rule);
  // Pixel 1 differs from pixel 0 by 19 in every channel (57 in all): it joins the arm.
  // Pixel 2 differs from pixel 0 by 20 in one channel only: it stops the arm.
  EXPECT_EQ(arms.right.at(0, 0), 1);
  EXPECT_EQ(arms.left.at(3, 0), 0);  // pixel 2 differs from pixel 3 by 20 in red
  EXPECT_EQ(arms.left.at(1, 0), 1);  // pixel 0 is 19 away in every channel
  // From pixel 1, pixel 2 is at most 19 away, pixel 3 too, but pixel 3 is 20 away from pixel 2.
  EXPECT_EQ(arms.right.at(1, 0), 1);
}

TEST(CrossArms, VerticalArmsFollowTheSameRule) {
  Image<std::uint8_t> img(1, 8);
  const int v[8] = {100, 100, 100, 140, 100, 100, 100, 100};
  for (int y = 0; y < 8; ++y) img.at(0, y) = static_cast<std::uint8_t>(v[y]);
  const CrossArms arms = arms_of(img, ArmRule{});
  EXPECT_EQ(arms.down.at(0, 0), 2);
  EXPECT_EQ(arms.up.at(0, 7), 3);
  EXPECT_EQ(arms.up.at(0, 3), 0);
  EXPECT_EQ(arms.down.at(0, 3), 0);
  EXPECT_EQ(arms.left.at(0, 5), 0);
  EXPECT_EQ(arms.right.at(0, 5), 0);
}

TEST(CrossArms, MatchesNaiveReferenceOnRandomImages) {
  std::mt19937 rng(42);
  const ArmRule rules[] = {ArmRule{}, ArmRule{8, 3, 30, 10}, ArmRule{255, 0, 255, 255},
                           ArmRule{5, 5, 1, 1}};
  for (int channels : {1, 3})
    for (const ArmRule& rule : rules)
      for (auto [w, h] : {std::pair{1, 1}, {7, 3}, {45, 38}}) {
        // Smooth-ish content so arms have all kinds of lengths.
        auto img = test::random_image<std::uint8_t>(rng, w, h, channels, 0, 24);
        for (int y = 0; y < h; ++y)
          for (int x = 0; x < w * channels; ++x)
            img.row(y)[x] = static_cast<std::uint8_t>(img.row(y)[x] + 4 * ((x / channels) / 9));
        const CrossArms arms = arms_of(img, rule);
        for (int y = 0; y < h; ++y)
          for (int x = 0; x < w; ++x) {
            ASSERT_EQ(arms.left.at(x, y), naive_arm(img, x, y, -1, 0, rule)) << x << "," << y;
            ASSERT_EQ(arms.right.at(x, y), naive_arm(img, x, y, 1, 0, rule)) << x << "," << y;
            ASSERT_EQ(arms.up.at(x, y), naive_arm(img, x, y, 0, -1, rule)) << x << "," << y;
            ASSERT_EQ(arms.down.at(x, y), naive_arm(img, x, y, 0, 1, rule)) << x << "," << y;
          }
      }
}

TEST(CrossArms, ArmsOfStridedSubViewIgnoreTheSurroundings) {
  // A flat 20x10 window inside a very different frame: the arms stop at the view's border.
  Image<std::uint8_t> big(40, 30);
  big.fill(0);
  for (int y = 5; y < 15; ++y)
    for (int x = 10; x < 30; ++x) big.at(x, y) = 200;
  CrossArms arms;
  compute_cross_arms(big.view().sub(10, 5, 20, 10), ArmRule{}, arms);
  ASSERT_EQ(arms.width(), 20);
  ASSERT_EQ(arms.height(), 10);
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 20; ++x) {
      ASSERT_EQ(arms.left.at(x, y), x);
      ASSERT_EQ(arms.right.at(x, y), 19 - x);
      ASSERT_EQ(arms.up.at(x, y), y);
      ASSERT_EQ(arms.down.at(x, y), 9 - y);
    }
}

TEST(CrossArms, GreyKernelGivesTheReferenceArmsOnAStridedView) {
  // Noisy patches inside a frame that differs: the byte kernel must see only the view.
  std::mt19937 rng(3);
  Image<std::uint8_t> big(300, 60);
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 300; ++x)
      big.at(x, y) = static_cast<std::uint8_t>(((x / 13) * 41 + (y / 6) * 23) % 256 + rng() % 6);
  const ImageView<const std::uint8_t> view = big.cview().sub(7, 3, 280, 50);
  for (const ArmRule rule : {ArmRule{}, ArmRule{17, 8, 20, 6}, ArmRule{255, 100, 255, 40}}) {
    CrossArms expected, arms;
    compute_cross_arms(view, rule, expected);
    compute_grey_cross_arms(view, rule, arms);
    ASSERT_EQ(arms.width(), 280);
    ASSERT_EQ(arms.height(), 50);
    for (int y = 0; y < 50; ++y)
      for (int x = 0; x < 280; ++x) {
        ASSERT_EQ(arms.left.at(x, y), expected.left.at(x, y)) << x << "," << y;
        ASSERT_EQ(arms.right.at(x, y), expected.right.at(x, y)) << x << "," << y;
        ASSERT_EQ(arms.up.at(x, y), expected.up.at(x, y)) << x << "," << y;
        ASSERT_EQ(arms.down.at(x, y), expected.down.at(x, y)) << x << "," << y;
      }
  }
}

TEST(CrossArms, GreyKernelRefusesColourImages) {
  Image<std::uint8_t> colour(20, 10, 3);
  colour.fill(0);
  CrossArms arms;
  EXPECT_THROW(compute_grey_cross_arms(colour.cview(), ArmRule{}, arms), Error);
}

TEST(SmoothCrossArms, RemovesOneRowSpikeAndOneColumnNotch) {
  const int w = 12, h = 9;
  CrossArms arms = test::full_arms(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      arms.left.at(x, y) = static_cast<std::uint8_t>(std::min(x, 3));
      arms.right.at(x, y) = static_cast<std::uint8_t>(std::min(w - 1 - x, 3));
      arms.up.at(x, y) = static_cast<std::uint8_t>(std::min(y, 2));
      arms.down.at(x, y) = static_cast<std::uint8_t>(std::min(h - 1 - y, 2));
    }
  const CrossArms expected = arms;
  // Row 4: left arms reach the image border (a spike); column 6: up arms are 0 (a notch).
  for (int x = 0; x < w; ++x) arms.left.at(x, 4) = static_cast<std::uint8_t>(x);
  for (int y = 0; y < h; ++y) arms.up.at(6, y) = 0;
  Image<std::uint8_t> scratch;
  smooth_cross_arms(arms, scratch);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      ASSERT_EQ(arms.left.at(x, y), expected.left.at(x, y)) << x << "," << y;
      ASSERT_EQ(arms.right.at(x, y), expected.right.at(x, y)) << x << "," << y;
      ASSERT_EQ(arms.up.at(x, y), expected.up.at(x, y)) << x << "," << y;
      ASSERT_EQ(arms.down.at(x, y), expected.down.at(x, y)) << x << "," << y;
    }
}

TEST(SmoothCrossArms, MedianAcrossTheArmDirectionOnly) {
  // A left-arm spike one column wide (along the arm direction) survives: the median runs over
  // the pixels above and below.
  const int w = 10, h = 5;
  CrossArms arms = test::full_arms(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) arms.left.at(x, y) = static_cast<std::uint8_t>(std::min(x, 1));
  for (int y = 0; y < h; ++y) arms.left.at(7, y) = 7;
  Image<std::uint8_t> scratch;
  smooth_cross_arms(arms, scratch);
  for (int y = 0; y < h; ++y) EXPECT_EQ(arms.left.at(7, y), 7);
  EXPECT_EQ(arms.left.at(6, 2), 1);
}

TEST(SmoothCrossArms, MatchesNaiveMedianAndStaysInsideTheImage) {
  std::mt19937 rng(7);
  for (auto [w, h] : {std::pair{1, 1}, {2, 5}, {31, 17}}) {
    CrossArms arms = test::random_arms(rng, w, h, 40);
    const CrossArms before = arms;
    Image<std::uint8_t> scratch;
    smooth_cross_arms(arms, scratch);
    const auto med = [](int a, int b, int c) {
      return std::max(std::min(a, b), std::min(std::max(a, b), c));
    };
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const int ya = std::max(y - 1, 0), yb = std::min(y + 1, h - 1);
        const int xa = std::max(x - 1, 0), xb = std::min(x + 1, w - 1);
        ASSERT_EQ(arms.left.at(x, y),
                  med(before.left.at(x, ya), before.left.at(x, y), before.left.at(x, yb)));
        ASSERT_EQ(arms.right.at(x, y),
                  med(before.right.at(x, ya), before.right.at(x, y), before.right.at(x, yb)));
        ASSERT_EQ(arms.up.at(x, y),
                  med(before.up.at(xa, y), before.up.at(x, y), before.up.at(xb, y)));
        ASSERT_EQ(arms.down.at(x, y),
                  med(before.down.at(xa, y), before.down.at(x, y), before.down.at(xb, y)));
        ASSERT_LE(arms.left.at(x, y), x);
        ASSERT_LE(arms.right.at(x, y), w - 1 - x);
        ASSERT_LE(arms.up.at(x, y), y);
        ASSERT_LE(arms.down.at(x, y), h - 1 - y);
      }
  }
}

TEST(SmoothCrossArms, SecondCallReusesScratchAndIsIdempotentOnMedianRoots) {
  // Arms constant along the smoothing direction are a fixed point of the median.
  CrossArms arms = test::full_arms(9, 6);
  const CrossArms before = arms;
  Image<std::uint8_t> scratch;
  smooth_cross_arms(arms, scratch);
  const std::uint8_t* data = scratch.data();
  smooth_cross_arms(arms, scratch);
  EXPECT_EQ(scratch.data(), data);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 9; ++x) {
      ASSERT_EQ(arms.left.at(x, y), before.left.at(x, y));
      ASSERT_EQ(arms.up.at(x, y), before.up.at(x, y));
    }
}

TEST(ShortestArm, IsTheMinimumOfTheFour) {
  CrossArms arms;
  arms.resize(2, 1);
  arms.left.at(0, 0) = 5;
  arms.right.at(0, 0) = 4;
  arms.up.at(0, 0) = 9;
  arms.down.at(0, 0) = 3;
  arms.left.at(1, 0) = 8;
  arms.right.at(1, 0) = 7;
  arms.up.at(1, 0) = 2;
  arms.down.at(1, 0) = 6;
  std::uint8_t shortest[2] = {};
  shortest_arm_row(arms, 0, shortest);
  EXPECT_EQ(shortest[0], 3);
  EXPECT_EQ(shortest[1], 2);
}

}  // namespace
}  // namespace dco::stereo
