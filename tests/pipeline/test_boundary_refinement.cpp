// The boundary refinement of the half-size stereo path: around a depth edge, each input pixel
// takes the side whose surface it really shows, decided at input resolution.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>

#include "dco/core/error.hpp"
#include "dco/core/image.hpp"
#include "dco/kernels/boundary_pixel.hpp"
#include "dco/pipeline/stereo/boundary_refinement.hpp"
#include "dco/pipeline/stereo/stereo_params.hpp"

namespace dco::stereo {
namespace {

namespace px = kernels::pixel;

constexpr float kNone = std::numeric_limits<float>::infinity();
constexpr int kWidth = 96, kHeight = 40;
constexpr int kFar = 8, kNear = 20;  // input px

// A textured bar (columns first..last) at disparity kNear in front of a textured wall at kFar,
// both images rendered exactly; the half-size map a matcher would give: every 2x2 block that
// holds a pixel of the bar has the bar's value (the edge fattened to the block), the wall's
// pixels hidden from the right camera have none.
struct BarScene {
  Image<std::uint8_t> left{kWidth, kHeight}, right{kWidth, kHeight};
  Image<float> truth{kWidth, kHeight};
  Image<float> internal{kWidth / 2, kHeight / 2};
  Image<float> expanded{kWidth, kHeight};

  BarScene(int first, int last, bool textured = true) {
    // The support weights assume that a surface's grey levels differ from its background's
    // more than among themselves: a light bar on a dark wall.
    std::mt19937 rng(7);
    std::uniform_int_distribution<int> dark(30, 110), light(140, 220);
    Image<std::uint8_t> wall(kWidth + kNear, kHeight), bar(kWidth + kNear, kHeight);
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth + kNear; ++x) {
        wall.row(y)[x] = static_cast<std::uint8_t>(textured ? dark(rng) : 100);
        bar.row(y)[x] = static_cast<std::uint8_t>(textured ? light(rng) : 100);
      }
    const auto on_bar = [&](int x) { return x >= first && x <= last; };
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x) {
        left.row(y)[x] = on_bar(x) ? bar.row(y)[x] : wall.row(y)[x];
        truth.row(y)[x] = on_bar(x) ? kNear : kFar;
        // Right image column x shows the bar where x + kNear is on it, else the wall.
        right.row(y)[x] = on_bar(x + kNear) ? bar.row(y)[x + kNear] : wall.row(y)[x + kFar];
      }
    // A wall pixel is hidden when the bar covers its place in the right image.
    const auto hidden = [&](int x) { return !on_bar(x) && on_bar(x - kFar + kNear); };
    for (int y = 0; y < kHeight / 2; ++y)
      for (int x = 0; x < kWidth / 2; ++x) {
        const bool bar_block = on_bar(2 * x) || on_bar(2 * x + 1);
        const bool hidden_block = hidden(2 * x) || hidden(2 * x + 1);
        internal.row(y)[x] = bar_block ? kNear / 2.0f : (hidden_block ? kNone : kFar / 2.0f);
      }
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x) expanded.row(y)[x] = 2.0f * internal.row(y / 2)[x / 2];
  }

  // Input pixels with a value on the wrong side of the edge.
  int wrong(ImageView<const float> d) const {
    int n = 0;
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x)
        if (d.row(y)[x] < kNone && std::abs(d.row(y)[x] - truth.row(y)[x]) > 1.0f) ++n;
    return n;
  }
};

TEST(BoundaryRefinement, PutsTheEdgeOfAFattenedBarOnItsInputPixel) {
  const BarScene s(41, 49);  // block 20 (columns 40, 41) straddles the bar's left edge
  Image<float> d(kWidth, kHeight);
  d.copy_from(s.expanded.cview());
  ASSERT_EQ(s.wrong(d.cview()), kHeight);  // column 40: the wall, given the bar's value
  BoundaryRefiner refiner;
  refiner.apply(s.internal.cview(), s.left.cview(), s.right.cview(), 2,
                boundary_rule(StereoParams{}), d.view());
  EXPECT_EQ(s.wrong(d.cview()), 0);
  int fixed = 0;
  for (int y = 0; y < kHeight; ++y) fixed += d.row(y)[40] == kFar ? 1 : 0;
  // The others are left without a value (a hidden column of the wall sits in their windows and
  // keeps the far side from winning by the ratio): none is wrong.
  EXPECT_GE(fixed, kHeight / 2);
  // Away from the edge nothing changes, and the bar itself keeps its value.
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < 20; ++x) EXPECT_EQ(d.row(y)[x], s.expanded.row(y)[x]) << x << "," << y;
    for (int x = 42; x <= 49; ++x) EXPECT_EQ(d.row(y)[x], kNear) << x << "," << y;
  }
}

TEST(BoundaryRefinement, KeepsAFingerThreePixelsWide) {
  const BarScene s(43, 45);  // blocks 21 and 22 (columns 42..45): a 3 px bar fattened to 4
  Image<float> d(kWidth, kHeight);
  d.copy_from(s.expanded.cview());
  ASSERT_GT(s.wrong(d.cview()), 0);
  BoundaryRefiner refiner;
  refiner.apply(s.internal.cview(), s.left.cview(), s.right.cview(), 2,
                boundary_rule(StereoParams{}), d.view());
  EXPECT_EQ(s.wrong(d.cview()), 0);
  for (int y = 4; y < kHeight - 4; ++y)
    for (int x = 43; x <= 45; ++x) EXPECT_EQ(d.row(y)[x], kNear) << x << "," << y;
}

// The bar's right rim and the wall beside it lost by the matcher: internal columns 27..33 have
// no value, so no depth edge lies within 2 internal px of columns 29..31. Internal column 30 (input
// 60, 61, the bar's last columns) has the bar 4 columns to its left and the wall 4 to its right.
void erase_right_rim(BarScene& s) {
  for (int y = 0; y < kHeight / 2; ++y)
    for (int x = 27; x <= 33; ++x) s.internal.row(y)[x] = kNone;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) s.expanded.row(y)[x] = 2.0f * s.internal.row(y / 2)[x / 2];
}

// Input pixels right of column 49 (away from the bar's left edge) with a wrong value.
int wrong_right_of_the_bar_middle(const BarScene& s, ImageView<const float> d) {
  int n = 0;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 50; x < kWidth; ++x)
      if (d.row(y)[x] < kNone && std::abs(d.row(y)[x] - s.truth.row(y)[x]) > 1.0f) ++n;
  return n;
}

TEST(BoundaryRefinement, HolesAFewPixelsFromAnEdgeFindBothSidesAlongTheRow) {
  BarScene s(41, 61);  // the bar covers internal columns 20..30
  erase_right_rim(s);
  const auto refine = [&](const StereoParams& p) {
    Image<float> d(kWidth, kHeight);
    d.copy_from(s.expanded.cview());
    BoundaryRefiner refiner;
    refiner.apply(s.internal.cview(), s.left.cview(), s.right.cview(), 2, boundary_rule(p),
                  d.view());
    return d;
  };
  // With the row search (default) the bar's last columns get its value, and no hole gets a
  // wrong one.
  const Image<float> with = refine(StereoParams{});
  EXPECT_EQ(wrong_right_of_the_bar_middle(s, with.cview()), 0);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 60; x <= 61; ++x) EXPECT_EQ(with.row(y)[x], kNear) << x << "," << y;
  // Without it they stay holes for the densifier: the edge is out of the 2 px reach.
  StereoParams off;
  off.boundary_hole_reach = 0;
  const Image<float> without = refine(off);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 54; x <= 67; ++x) EXPECT_EQ(without.row(y)[x], kNone) << x << "," << y;
}

TEST(BoundaryRefinement, HolesFoundAlongTheRowAreDecidedByTheirOwnRatio) {
  // Sensor noise in the right image: no side matches perfectly, so the ratio decides.
  BarScene s(41, 61);
  erase_right_rim(s);
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> noise(-12, 12);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x)
      s.right.row(y)[x] =
          static_cast<std::uint8_t>(std::clamp(s.right.row(y)[x] + noise(rng), 0, 255));
  const auto decided_rim = [&](double ratio, double hole_ratio) {
    StereoParams p;
    p.boundary_ratio = ratio;
    p.boundary_hole_ratio = hole_ratio;
    Image<float> d(kWidth, kHeight);
    d.copy_from(s.expanded.cview());
    BoundaryRefiner refiner;
    refiner.apply(s.internal.cview(), s.left.cview(), s.right.cview(), 2, boundary_rule(p),
                  d.view());
    int n = 0;
    for (int y = 0; y < kHeight; ++y)
      for (int x = 54; x <= 67; ++x) n += d.row(y)[x] < kNone ? 1 : 0;
    return n;
  };
  EXPECT_GE(decided_rim(0.01, 1.0), kHeight);
  EXPECT_EQ(decided_rim(1.0, 0.01), 0);
}

TEST(BoundaryRefinement, AnUndecidableSideGetsNoGuess) {
  // Without texture both sides match equally well: values that passed the checks stay, holes
  // stay holes.
  const BarScene s(41, 49, /*textured=*/false);
  Image<float> d(kWidth, kHeight);
  d.copy_from(s.expanded.cview());
  BoundaryRefiner refiner;
  refiner.apply(s.internal.cview(), s.left.cview(), s.right.cview(), 2,
                boundary_rule(StereoParams{}), d.view());
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) EXPECT_EQ(d.row(y)[x], s.expanded.row(y)[x]) << x << "," << y;
}

// Refines a random half-size map (a hole where hole_draw(rng) == 0 out of 0..4) with random
// images by the CPU stage and by the shared per-pixel functions (the GPU passes) and expects the
// same output; returns how many pixels the functions changed, and of those how many only the row
// search for holes reached.
struct PerPixelCheck {
  int changed = 0, by_row_search = 0;
};

PerPixelCheck expect_the_per_pixel_functions(int holes_of_five, const StereoParams& params) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> grey(0, 255), value(0, 40), hole(0, 4);
  constexpr int w = 37, h = 23;
  Image<float> internal(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      internal.row(y)[x] =
          hole(rng) < holes_of_five ? kNone : static_cast<float>(value(rng)) / 4.0f + 1.0f;
  Image<std::uint8_t> left(2 * w + 1, 2 * h + 1), right(2 * w + 1, 2 * h + 1);
  for (int y = 0; y < left.height(); ++y)
    for (int x = 0; x < left.width(); ++x) {
      left.row(y)[x] = static_cast<std::uint8_t>(grey(rng));
      right.row(y)[x] = static_cast<std::uint8_t>(grey(rng));
    }
  Image<float> d(left.width(), left.height()), expected(left.width(), left.height());
  for (int y = 0; y < d.height(); ++y)
    for (int x = 0; x < d.width(); ++x)
      d.row(y)[x] = 2.0f * internal.row(std::min(y / 2, h - 1))[std::min(x / 2, w - 1)];
  const px::BoundaryRule rule = boundary_rule(params);
  const px::GreyPair im{left.data(),         right.data(), left.view().stride,
                        right.view().stride, left.width(), left.height()};
  PerPixelCheck check;
  for (int y = 0; y < d.height(); ++y)
    for (int x = 0; x < d.width(); ++x) {
      const int ix = std::min(x / 2, w - 1), iy = std::min(y / 2, h - 1);
      const px::SideRange narrow =
          px::side_range(internal.data(), internal.view().stride, w, h, ix, iy);
      const px::SideRange wide =
          px::side_range(internal.data(), internal.view().stride, w, h, ix, iy, rule.hole_reach);
      expected.row(y)[x] =
          px::refined_boundary_value(im, x, y, d.row(y)[x], narrow, wide, 2.0f, rule);
      const float before = d.row(y)[x];
      const float after = expected.row(y)[x];
      const bool changed = !(before == after || (std::isinf(before) && std::isinf(after)));
      check.changed += changed ? 1 : 0;
      check.by_row_search += changed && !px::spans_depth_edge(narrow) ? 1 : 0;
    }
  BoundaryRefiner refiner;
  refiner.apply(internal.cview(), left.cview(), right.cview(), 2, rule, d.view());
  for (int y = 0; y < d.height(); ++y)
    for (int x = 0; x < d.width(); ++x) {
      const float a = d.row(y)[x], b = expected.row(y)[x];
      EXPECT_TRUE(a == b || (std::isinf(a) && std::isinf(b))) << x << "," << y;
    }
  return check;
}

TEST(BoundaryRefinement, IsThePerPixelFunctionsEverywhere) {
  // The CPU stage finds the sides separably; it must give what the shared per-pixel functions
  // (the GPU passes) give: on a map with holes and many small jumps, and on one mostly of holes,
  // where the row search decides pixels (with a ratio that lets random images decide some).
  EXPECT_GT(expect_the_per_pixel_functions(1, StereoParams{}).changed, 50);
  StereoParams lax;
  lax.boundary_hole_ratio = 0.95;
  EXPECT_GT(expect_the_per_pixel_functions(4, lax).by_row_search, 20);
  // The row windows are built from blocks of 2^k columns: reaches whose window is one block
  // level with the narrow one's (3), two levels above it (7), the widest (16), and no row
  // search (2).
  for (const int reach : {2, 3, 7, 16}) {
    lax.boundary_hole_reach = reach;
    const PerPixelCheck check = expect_the_per_pixel_functions(4, lax);
    EXPECT_GT(check.changed, 20) << "hole reach " << reach << ": " << check.by_row_search;
    if (reach > 2) {
      EXPECT_GT(check.by_row_search, 5) << "hole reach " << reach;
    }
  }
}

TEST(BoundaryRefinement, RunsOnlyForHalfSizeMatchingWithAWindow) {
  StereoParams p;
  EXPECT_TRUE(refines_boundaries(p, 2));
  EXPECT_FALSE(refines_boundaries(p, 1));
  p.boundary_radius = 0;
  EXPECT_FALSE(refines_boundaries(p, 2));
}

TEST(BoundaryRefinement, RejectsAWindowOrRatioOutOfRange) {
  StereoParams p;
  p.boundary_radius = 16;
  EXPECT_THROW(validate(p), Error);
  p = StereoParams{};
  p.boundary_ratio = 0.0;
  EXPECT_THROW(validate(p), Error);
  p.boundary_ratio = 1.5;
  EXPECT_THROW(validate(p), Error);
  p = StereoParams{};
  p.boundary_hole_reach = 17;
  EXPECT_THROW(validate(p), Error);
  p.boundary_hole_reach = -1;
  EXPECT_THROW(validate(p), Error);
  p = StereoParams{};
  p.boundary_hole_ratio = 0.0;
  EXPECT_THROW(validate(p), Error);
  p.boundary_hole_ratio = 1.01;
  EXPECT_THROW(validate(p), Error);
}

TEST(BoundaryRefinement, RuleHoldsTheRatioAndFallingWeights) {
  StereoParams p;
  p.boundary_ratio = 0.5;
  p.boundary_radius = 5;
  const px::BoundaryRule rule = boundary_rule(p);
  EXPECT_EQ(rule.radius, 5);
  EXPECT_EQ(rule.keep, 128u);
  EXPECT_EQ(rule.hole_reach, p.boundary_hole_reach);
  EXPECT_EQ(rule.hole_keep, static_cast<std::uint32_t>(std::lround(p.boundary_hole_ratio * 256)));
  EXPECT_EQ(rule.weight[0], px::kBoundaryWeightOne);
  for (int i = 1; i < 256; ++i) EXPECT_LE(rule.weight[i], rule.weight[i - 1]);
  EXPECT_LT(rule.weight[30], rule.weight[0] / 10);
}

}  // namespace
}  // namespace dco::stereo
