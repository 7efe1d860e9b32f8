#include "dco/pipeline/stereo/disparity_selection.hpp"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <initializer_list>
#include <random>
#include <tuple>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "dco/kernels/stereo_pixel.hpp"

namespace dco::stereo {
namespace {

constexpr std::uint16_t kNo = WinnerTakesAll::kNoCost;
constexpr std::int16_t kInv = kInvalidDisparity;

// costs[x][d] for a one-row image.
WinnerTakesAll wta_of_row(const std::vector<std::vector<std::uint32_t>>& costs) {
  const int w = static_cast<int>(costs.size());
  const int disparities = static_cast<int>(costs[0].size());
  WinnerTakesAll wta;
  wta.reset(w, 1);
  Image<std::uint32_t> slice(w, 1);
  for (int d = 0; d < disparities; ++d) {
    for (int x = 0; x < w; ++x) slice.at(x, 0) = costs[x][d];
    wta.update(slice.cview(), d);
  }
  return wta;
}

struct Expect {
  int disp;
  int best, second, below, above;
};

void expect_pixel(const WinnerTakesAll& wta, int x, const Expect& e) {
  EXPECT_EQ(wta.left_disparity().at(x, 0), e.disp) << "x " << x;
  EXPECT_EQ(wta.best_cost().at(x, 0), e.best) << "x " << x;
  EXPECT_EQ(wta.second_cost().at(x, 0), e.second) << "x " << x;
  EXPECT_EQ(wta.cost_below().at(x, 0), e.below) << "x " << x;
  EXPECT_EQ(wta.cost_above().at(x, 0), e.above) << "x " << x;
}

TEST(WinnerTakesAll, HandMadeSlices) {
  const auto wta = wta_of_row({
      {50, 30, 10, 40, 60},  // clear winner at 2; non-adjacent costs 50 and 60
      {20, 10, 30, 10, 40},  // tie at 1 and 3: the smaller d wins, the other is the second best
      {10, 10, 50, 60, 70},  // adjacent tie: not a second best
      {100, 5, 6, 7, 100},   // second best skips d = 2 (adjacent), takes d = 3
      {3, 9, 9, 9, 9},       // winner at d = 0: nothing below
      {9, 9, 9, 9, 3},       // winner at the last d: nothing above
      {40, 50, 30, 35, 20},  // the winner moves twice
      {7, 7, 7, 7, 7},       // flat
  });
  expect_pixel(wta, 0, {2, 10, 50, 30, 40});
  expect_pixel(wta, 1, {1, 10, 10, 20, 30});
  expect_pixel(wta, 2, {0, 10, 50, kNo, 10});
  expect_pixel(wta, 3, {1, 5, 7, 100, 6});
  expect_pixel(wta, 4, {0, 3, 9, kNo, 9});
  expect_pixel(wta, 5, {4, 3, 9, 9, kNo});
  expect_pixel(wta, 6, {4, 20, 30, 35, kNo});
  expect_pixel(wta, 7, {0, 7, 7, kNo, 7});
}

TEST(WinnerTakesAll, SecondBestNeedsTwoDisparitiesOfDistance) {
  // Only two disparities: both adjacent, so no second best exists.
  const auto two = wta_of_row({{4, 8}, {8, 4}});
  expect_pixel(two, 0, {0, 4, kNo, kNo, 8});
  expect_pixel(two, 1, {1, 4, kNo, 8, kNo});
  // A single disparity.
  const auto one = wta_of_row({{5}});
  expect_pixel(one, 0, {0, 5, kNo, kNo, kNo});
}

TEST(WinnerTakesAll, RightImageWinnerUsesTheSameSlices) {
  // Right pixel xr at disparity d is left pixel xr + d.
  // Width 4, disparities 0..2; costs[x][d].
  const auto wta = wta_of_row({
      {9, 9, 9},  // x = 0: only d = 0 exists for it on the right (xr = 0)
      {9, 1, 9},  // x = 1, d = 1 -> xr = 0, cost 1
      {5, 9, 2},  // x = 2, d = 2 -> xr = 0, cost 2; d = 0 -> xr = 2
      {9, 3, 9},  // x = 3, d = 1 -> xr = 2, cost 3 (better than the 5 at d = 0)
  });
  const auto right = wta.right_disparity();
  // xr = 0: candidates (x0,d0)=9, (x1,d1)=1, (x2,d2)=2 -> d = 1.
  EXPECT_EQ(right.at(0, 0), 1);
  // xr = 1: (x1,d0)=9, (x2,d1)=9, (x3,d2)=9 -> tie everywhere, the smallest d.
  EXPECT_EQ(right.at(1, 0), 0);
  // xr = 2: (x2,d0)=5, (x3,d1)=3 -> d = 1.
  EXPECT_EQ(right.at(2, 0), 1);
  // xr = 3: only (x3,d0)=9.
  EXPECT_EQ(right.at(3, 0), 0);
  // And the left winners for comparison.
  EXPECT_EQ(wta.left_disparity().at(1, 0), 1);
  EXPECT_EQ(wta.left_disparity().at(2, 0), 2);
  EXPECT_EQ(wta.left_disparity().at(3, 0), 1);
}

struct Reference {
  int disp;
  std::uint16_t best, second, below, above;
};

TEST(WinnerTakesAll, MatchesBruteForceOnRandomVolumes) {
  std::mt19937 rng(17);
  for (auto [w, h, disparities, max_cost] :
       {std::tuple{13, 5, 1, 20}, {13, 5, 2, 20}, {31, 9, 7, 12}, {40, 6, 24, 4096}}) {
    std::uniform_int_distribution<int> cost(0, max_cost);
    std::vector<Image<std::uint32_t>> vol;
    WinnerTakesAll wta;
    wta.reset(w, h);
    for (int d = 0; d < disparities; ++d) {
      Image<std::uint32_t> s(w, h);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) s.at(x, y) = static_cast<std::uint32_t>(cost(rng));
      wta.update(s.cview(), d);
      vol.push_back(std::move(s));
    }
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        int best_d = 0;
        for (int d = 1; d < disparities; ++d)
          if (vol[d].at(x, y) < vol[best_d].at(x, y)) best_d = d;
        std::uint32_t second = kNo;
        for (int d = 0; d < disparities; ++d)
          if ((d < best_d - 1 || d > best_d + 1) && vol[d].at(x, y) < second)
            second = vol[d].at(x, y);
        const std::uint32_t below = best_d > 0 ? vol[best_d - 1].at(x, y) : kNo;
        const std::uint32_t above = best_d + 1 < disparities ? vol[best_d + 1].at(x, y) : kNo;
        ASSERT_EQ(wta.left_disparity().at(x, y), best_d) << x << "," << y;
        ASSERT_EQ(wta.best_cost().at(x, y), vol[best_d].at(x, y)) << x << "," << y;
        ASSERT_EQ(wta.second_cost().at(x, y), second) << x << "," << y;
        ASSERT_EQ(wta.cost_below().at(x, y), below) << x << "," << y;
        ASSERT_EQ(wta.cost_above().at(x, y), above) << x << "," << y;

        // Right pixel x: the first d with the smallest cost among the left pixels x + d.
        int right_d = 0;
        std::uint32_t right_best = vol[0].at(x, y);
        for (int d = 1; d < disparities && x + d < w; ++d)
          if (vol[d].at(x + d, y) < right_best) {
            right_best = vol[d].at(x + d, y);
            right_d = d;
          }
        ASSERT_EQ(wta.right_disparity().at(x, y), right_d) << x << "," << y;
      }
    // reset() starts a fresh frame: feeding the same volume again gives the same answer.
    const Image<std::int16_t> first = [&] {
      Image<std::int16_t> c(w, h);
      c.copy_from(wta.left_disparity());
      return c;
    }();
    wta.reset(w, h);
    for (int d = 0; d < disparities; ++d) wta.update(vol[d].cview(), d);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) ASSERT_EQ(wta.left_disparity().at(x, y), first.at(x, y));
  }
}

// Each row leaves random runs of disparities out (skip_row); the state must be that of a search
// over the remaining ones: a neighbour left out gives no subpixel cost, and neither can win or
// be second.
TEST(WinnerTakesAll, SkippedDisparitiesAreLeftOutOfTheSearch) {
  std::mt19937 rng(23);
  const int w = 29, h = 12, disparities = 21;
  std::uniform_int_distribution<int> cost(0, 40), run(1, 4), coin(0, 2);
  std::vector<Image<std::uint16_t>> vol;
  for (int d = 0; d < disparities; ++d) {
    Image<std::uint16_t> s(w, h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) s.at(x, y) = static_cast<std::uint16_t>(cost(rng));
    vol.push_back(std::move(s));
  }
  std::vector<std::vector<bool>> searched(h, std::vector<bool>(disparities));
  WinnerTakesAll wta;
  wta.reset(w, h);
  std::vector<std::uint16_t> costs(static_cast<std::size_t>(w) * 4);
  for (int y = 0; y < h; ++y)
    for (int d = 0; d < disparities;) {
      const int count = std::min(run(rng), disparities - d);
      const bool search = coin(rng) != 0;
      for (int k = 0; k < count; ++k) searched[y][d + k] = search;
      if (search) {
        for (int k = 0; k < count; ++k)
          for (int x = 0; x < w; ++x) costs[k * w + x] = vol[d + k].at(x, y);
        wta.update_row(costs.data(), w, count, y, d);
      } else {
        wta.skip_row(y, d, count);
      }
      d += count;
    }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const auto at = [&](int d) -> std::uint32_t {
        return d >= 0 && d < disparities && searched[y][d] ? vol[d].at(x, y) : kNo;
      };
      int best_d = kInv;
      std::uint32_t best = kNo;
      for (int d = 0; d < disparities; ++d)
        if (at(d) < best) best = at(d), best_d = d;
      std::uint32_t second = kNo;
      for (int d = 0; d < disparities; ++d)
        if ((d < best_d - 1 || d > best_d + 1) && at(d) < second) second = at(d);
      SCOPED_TRACE(testing::Message() << x << "," << y);
      ASSERT_EQ(wta.left_disparity().at(x, y), best_d);
      ASSERT_EQ(wta.best_cost().at(x, y), best);
      ASSERT_EQ(wta.second_cost().at(x, y), second);
      ASSERT_EQ(wta.cost_below().at(x, y), best_d == kInv ? kNo : at(best_d - 1));
      ASSERT_EQ(wta.cost_above().at(x, y), best_d == kInv ? kNo : at(best_d + 1));
      int right_d = kInv;
      std::uint32_t right_best = kNo;
      for (int d = 0; d < disparities && x + d < w; ++d)
        if (searched[y][d] && vol[d].at(x + d, y) < right_best)
          right_best = vol[d].at(x + d, y), right_d = d;
      ASSERT_EQ(wta.right_disparity().at(x, y), right_d);
    }
}

// Reset starts the right image's state; the left image's starts with each pixel's disparity 0,
// skipped or fed, whatever a previous frame left in it.
TEST(WinnerTakesAll, ResetAndDisparityZeroStartAfresh) {
  WinnerTakesAll wta;
  const std::vector<std::uint16_t> costs = {7, 3, 9, 1, 4, 2};  // disparities 0 and 1, 3 columns
  for (const bool skip_first : {true, false}) {
    wta.reset(3, 2);
    for (int y = 0; y < 2; ++y) wta.update_row(costs.data(), 3, 2, y, 0);  // a previous frame
    ASSERT_NE(wta.best_cost().at(0, 0), kNo);
    wta.reset(3, 2);
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 3; ++x) {
        EXPECT_EQ(wta.right_disparity().at(x, y), kInv);
      }
    const std::vector<std::uint16_t> none(3, kNo);
    for (int y = 0; y < 2; ++y) {
      if (skip_first)
        wta.skip_row(y, 0, 1);
      else
        wta.update_row(none.data(), 3, 1, y, 0);
    }
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 3; ++x) {
        EXPECT_EQ(wta.left_disparity().at(x, y), kInv) << skip_first;
        EXPECT_EQ(wta.right_disparity().at(x, y), kInv) << skip_first;
        EXPECT_EQ(wta.best_cost().at(x, y), kNo) << skip_first;
        EXPECT_EQ(wta.second_cost().at(x, y), kNo) << skip_first;
        EXPECT_EQ(wta.cost_below().at(x, y), kNo) << skip_first;
        EXPECT_EQ(wta.cost_above().at(x, y), kNo) << skip_first;
      }
  }
}

Image<std::int16_t> row16(std::initializer_list<int> v) {
  Image<std::int16_t> img(static_cast<int>(v.size()), 1);
  int x = 0;
  for (int d : v) img.at(x++, 0) = static_cast<std::int16_t>(d);
  return img;
}

std::vector<int> values(const Image<std::int16_t>& img) {
  std::vector<int> out;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) out.push_back(img.at(x, y));
  return out;
}

TEST(LeftRightCheck, MarksInconsistentAndOutOfImagePixels) {
  const auto right = row16({0, 1, 1, 9, kInv, 3, 0, 0, 0});
  const auto left = row16({kInv, 0, 1, 2, 5, 3, 3, 3, 3});
  // x=1 -> xr 1 (1 vs 0); x=2 -> xr 1 (1 vs 1); x=3 -> xr 1 (1 vs 2); x=4 -> xr -1;
  // x=5 -> xr 2 (1 vs 3); x=6 -> xr 3 (9 vs 3); x=7 -> xr 4 (invalid); x=8 -> xr 5 (3 vs 3).
  std::vector<std::int32_t> scratch;
  auto l1 = left;
  left_right_check(l1.view(), right.cview(), 1, scratch);
  EXPECT_EQ(values(l1), (std::vector<int>{kInv, 0, 1, 2, kInv, kInv, kInv, kInv, 3}));
  auto l0 = left;
  left_right_check(l0.view(), right.cview(), 0, scratch);
  EXPECT_EQ(values(l0), (std::vector<int>{kInv, kInv, 1, kInv, kInv, kInv, kInv, kInv, 3}));
  auto l8 = left;
  left_right_check(l8.view(), right.cview(), 8, scratch);
  EXPECT_EQ(values(l8), (std::vector<int>{kInv, 0, 1, 2, kInv, 3, 3, kInv, 3}));
}

TEST(LeftRightCheck, ConsistentPlaneSurvivesAndRowsAreIndependent) {
  Image<std::int16_t> left(20, 3), right(20, 3);
  left.fill(4);
  right.fill(4);
  right.at(6, 1) = 7;  // breaks left pixel 10 of row 1 only
  std::vector<std::int32_t> scratch;
  left_right_check(left.view(), right.cview(), 1, scratch);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 20; ++x) {
      const bool out = x < 4 || (y == 1 && x == 10);
      ASSERT_EQ(left.at(x, y), out ? kInv : 4) << x << "," << y;
    }
}

TEST(UniquenessCheck, KeepsOnlyClearWinners) {
  auto disp = row16({3, 3, 3, kInv, 3, 3, 3});
  Image<std::uint16_t> best(7, 1), second(7, 1);
  const int b[7] = {80, 90, 90, 10, 84, 86, 50};
  const int s[7] = {100, 100, kNo, 100, 100, 100, 50};
  for (int x = 0; x < 7; ++x) {
    best.at(x, 0) = static_cast<std::uint16_t>(b[x]);
    second.at(x, 0) = static_cast<std::uint16_t>(s[x]);
  }
  auto d15 = disp;
  uniqueness_check(d15.view(), best.cview(), second.cview(), 0.15);
  // 80 <= 85 keeps, 90 does not, no second best keeps, invalid stays invalid, 84 keeps,
  // 86 does not, a tie does not.
  EXPECT_EQ(values(d15), (std::vector<int>{3, kInv, 3, kInv, 3, kInv, kInv}));
  auto d0 = disp;
  uniqueness_check(d0.view(), best.cview(), second.cview(), 0.0);
  EXPECT_EQ(values(d0), values(disp));  // ratio 0: best <= second always holds
  auto d5 = disp;
  uniqueness_check(d5.view(), best.cview(), second.cview(), 0.5);
  EXPECT_EQ(values(d5), (std::vector<int>{kInv, kInv, 3, kInv, kInv, kInv, kInv}));
  // Exactly half is still "at least 50 % below".
  Image<std::uint16_t> b50(1, 1), s50(1, 1);
  b50.at(0, 0) = 50;
  s50.at(0, 0) = 100;
  auto one = row16({2});
  uniqueness_check(one.view(), b50.cview(), s50.cview(), 0.5);
  EXPECT_EQ(one.at(0, 0), 2);
}

TEST(UniquenessCheck, BestExactlyRatioBelowSecondIsKept) {
  Image<std::uint16_t> best(1, 1), second(1, 1);
  best.at(0, 0) = 850;
  second.at(0, 0) = 1000;
  auto disp = row16({5});
  uniqueness_check(disp.view(), best.cview(), second.cview(), 0.15);
  EXPECT_EQ(disp.at(0, 0), 5);
}

Image<std::int16_t> grid16(const std::vector<std::vector<int>>& rows) {
  Image<std::int16_t> img(static_cast<int>(rows[0].size()), static_cast<int>(rows.size()));
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) img.at(x, y) = static_cast<std::int16_t>(rows[y][x]);
  return img;
}

TEST(DiscontinuityCheck, DropsTheFarSideOfAStepAndKeepsFlatAreas) {
  Image<std::int16_t> scratch;
  auto disp =
      grid16({{5, 5, 5, 5, 9, 9, 9, 9}, {5, 5, 5, 5, 9, 9, 9, 9}, {5, 5, 5, 5, 9, 9, 9, 9}});
  const auto original = disp;
  discontinuity_check(disp.view(), 1, scratch);
  // Column 3 (disparity 5) is behind its neighbours in column 4 (9): it goes; column 4 stays.
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 8; ++x)
      ASSERT_EQ(disp.at(x, y), x == 3 ? kInv : original.at(x, y)) << x << "," << y;
  // A jump equal to max_jump is allowed.
  disp = original;
  discontinuity_check(disp.view(), 4, scratch);
  EXPECT_EQ(values(disp), values(original));
  disp = original;
  discontinuity_check(disp.view(), 3, scratch);
  EXPECT_EQ(disp.at(3, 1), kInv);
  EXPECT_EQ(disp.at(4, 1), 9);
  EXPECT_EQ(disp.at(2, 1), 5);
}

// A near object one pixel wide (a finger at half resolution) keeps its pixels; the far pixels on
// both sides of it go.
TEST(DiscontinuityCheck, KeepsAThinNearObject) {
  Image<std::int16_t> scratch;
  auto disp = row16({5, 5, 5, 20, 5, 5, 5});
  discontinuity_check(disp.view(), 1, scratch);
  EXPECT_EQ(values(disp), (std::vector<int>{5, 5, kInv, 20, kInv, 5, 5}));
}

TEST(DiscontinuityCheck, DecidesOnTheInputNotOnPixelsAlreadyDropped) {
  Image<std::int16_t> scratch;
  // Column 1 is behind column 2, column 2 behind column 3: both go, although column 2 is gone by
  // the time column 1 would look at the map being written.
  auto disp = row16({5, 5, 9, 13, 13});
  discontinuity_check(disp.view(), 1, scratch);
  EXPECT_EQ(values(disp), (std::vector<int>{5, kInv, kInv, 13, 13}));
}

TEST(DiscontinuityCheck, IgnoresInvalidNeighboursAndUsesDiagonals) {
  Image<std::int16_t> scratch;
  auto gap = row16({5, 5, kInv, 9, 9});
  discontinuity_check(gap.view(), 1, scratch);
  EXPECT_EQ(values(gap), (std::vector<int>{5, 5, kInv, 9, 9}));

  auto corner = grid16({{5, 5, 5}, {5, 5, 5}, {5, 5, 9}});
  discontinuity_check(corner.view(), 2, scratch);
  EXPECT_EQ(values(corner), (std::vector<int>{5, 5, 5, 5, kInv, kInv, 5, kInv, 9}));
}

// The row-maximum formulation against the per-pixel rule the GPU path runs, on random maps with
// holes, every size from one pixel up and every max_jump the parameters allow.
TEST(DiscontinuityCheck, EqualsThePerPixelRule) {
  std::mt19937 rng(11);
  Image<std::int16_t> scratch;
  for (const auto& [w, h] : {std::pair{1, 1}, {1, 5}, {6, 1}, {2, 2}, {17, 9}, {64, 33}})
    for (const int max_jump : {-1, 0, 1, 3, 64}) {
      Image<std::int16_t> disp(w, h);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          disp.at(x, y) = rng() % 5 == 0 ? kInv : static_cast<std::int16_t>(rng() % 12);
      const Image<std::int16_t> before = disp;
      const auto at = [&before](int x, int y) { return int{before.at(x, y)}; };
      discontinuity_check(disp.view(), max_jump, scratch);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const bool dropped =
              before.at(x, y) != kInv && kernels::pixel::behind_jump(at, x, y, w, h, max_jump);
          ASSERT_EQ(disp.at(x, y), dropped ? kInv : before.at(x, y))
              << w << "x" << h << " jump " << max_jump << " at " << x << "," << y;
        }
    }
}

TEST(DiscontinuityCheck, SmoothSlopeSurvivesUnlessMaxJumpIsZero) {
  Image<std::int16_t> scratch;
  Image<std::int16_t> ramp(10, 4);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 10; ++x) ramp.at(x, y) = static_cast<std::int16_t>(10 + x);
  auto kept = ramp;
  discontinuity_check(kept.view(), 1, scratch);
  EXPECT_EQ(values(kept), values(ramp));
  // With max_jump 0 every pixel is behind its right-hand neighbour, except the nearest column.
  auto dropped = ramp;
  discontinuity_check(dropped.view(), 0, scratch);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 10; ++x) EXPECT_EQ(dropped.at(x, y), x == 9 ? 19 : kInv) << x << "," << y;
}

// The islands of cv::filterSpeckles, removed the same way: maps of small values with many
// invalid pixels, so that islands of every size and shape occur.
TEST(SpeckleFilter, RemovesTheIslandsOpenCvRemoves) {
  std::mt19937 rng(11);
  SpeckleFilter filter;  // one filter for every size: its work area is reused
  int removed = 0, kept = 0;
  for (const auto& [w, h] : {std::pair{1, 1}, std::pair{1, 40}, std::pair{40, 1}, std::pair{7, 5},
                             std::pair{64, 48}, std::pair{33, 65}})
    for (const int max_size : {1, 2, 3, 4, 5, 8, 30})
      for (const int max_diff : {0, 1, 2})
        for (const int invalid_share : {2, 4, 8}) {
          Image<std::int16_t> map(w, h);
          for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
              map.at(x, y) = static_cast<std::int16_t>(
                  rng() % invalid_share == 0 ? kInv : static_cast<int>(rng() % 5) + 3 * (x / 9));
          cv::Mat expected(h, w, CV_16SC1);
          for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) expected.at<std::int16_t>(y, x) = map.at(x, y);
          cv::filterSpeckles(expected, kInv, max_size, max_diff);
          for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
              removed += map.at(x, y) != kInv && expected.at<std::int16_t>(y, x) == kInv;
          filter.apply(map.view(), max_size, max_diff);
          for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
              ASSERT_EQ(map.at(x, y), expected.at<std::int16_t>(y, x))
                  << w << "x" << h << " max_size " << max_size << " max_diff " << max_diff << " at "
                  << x << "," << y;
              kept += map.at(x, y) != kInv;
            }
        }
  // Both outcomes occur often.
  std::printf("%d pixels removed, %d kept\n", removed, kept);
  EXPECT_GT(removed, 1000);
  EXPECT_GT(kept, 1000);
}

TEST(SubpixelOffset, ExactOnASampledV) {
  // 64 |t + 0.375| + 100 at t = -1, 0, 1.
  EXPECT_FLOAT_EQ(subpixel_offset(140, 124, 188), -0.375f);
  EXPECT_FLOAT_EQ(subpixel_offset(188, 124, 140), 0.375f);
  // 40 |t - 0.25| + 100: tip at 0.25.
  EXPECT_FLOAT_EQ(subpixel_offset(150, 110, 130), 0.25f);
  EXPECT_FLOAT_EQ(subpixel_offset(20, 10, 20), 0.0f);   // symmetric
  EXPECT_FLOAT_EQ(subpixel_offset(10, 10, 30), -0.5f);  // tip on the d-1/d midpoint
}

// On a V a parabola fit leans towards the whole pixel (the pixel-locking the V fit avoids).
TEST(SubpixelOffset, UnbiasedWhereAParabolaLocksToThePixel) {
  // 64 |t - 0.25| + 100 at t = -1, 0, 1: a parabola through these puts the tip at 0.1667.
  const float v = subpixel_offset(180, 116, 148);
  EXPECT_FLOAT_EQ(v, 0.25f);
  const float parabola = float(180 - 148) / (2.0f * float(180 + 148 - 2 * 116));
  EXPECT_LT(parabola, 0.2f);
}

TEST(SubpixelOffset, ZeroWithoutAMinimumOrNeighbour) {
  EXPECT_EQ(subpixel_offset(10, 10, 10), 0.0f);  // flat
  EXPECT_EQ(subpixel_offset(5, 10, 5), 0.0f);    // not a minimum
  EXPECT_EQ(subpixel_offset(20, 10, 0), 0.0f);   // a neighbour below the winner
  EXPECT_EQ(subpixel_offset(kNo, 10, 20), 0.0f);
  EXPECT_EQ(subpixel_offset(20, 10, kNo), 0.0f);
  EXPECT_EQ(subpixel_offset(kNo, 10, kNo), 0.0f);
}

TEST(SubpixelOffset, NeverBeyondHalfAPixel) {
  EXPECT_EQ(subpixel_offset(20, 20, 100), -0.5f);  // the tip on the d-1/d midpoint
  EXPECT_EQ(subpixel_offset(100, 20, 20), 0.5f);
  for (int below = 7; below < 60; below += 3)
    for (int above = 7; above < 60; above += 5) {
      const float o =
          subpixel_offset(static_cast<std::uint16_t>(below), 7, static_cast<std::uint16_t>(above));
      ASSERT_GE(o, -0.5f);
      ASSERT_LE(o, 0.5f);
    }
}

}  // namespace
}  // namespace dco::stereo
