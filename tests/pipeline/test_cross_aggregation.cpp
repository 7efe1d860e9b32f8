#include "dco/pipeline/stereo/cross_aggregation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <random>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "pipeline_test_support.hpp"

namespace dco::stereo {
namespace {

using Sums = std::vector<std::uint64_t>;  // row-major, exact

Sums hsum_ref(const Image<std::uint32_t>& in, const CrossArms& a) {
  const int w = in.width(), h = in.height();
  Sums out(static_cast<std::size_t>(w) * h, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int i = x - a.left.at(x, y); i <= x + a.right.at(x, y); ++i)
        out[y * w + x] += in.at(i, y);
  return out;
}

Sums vsum_ref(const Image<std::uint32_t>& in, const CrossArms& a) {
  const int w = in.width(), h = in.height();
  Sums out(static_cast<std::size_t>(w) * h, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int j = y - a.up.at(x, y); j <= y + a.down.at(x, y); ++j) out[y * w + x] += in.at(x, j);
  return out;
}

// Region sum of Eq. 2: horizontal-first takes the horizontal arms of every pixel on p's vertical
// arm, vertical-first the vertical arms of every pixel on p's horizontal arm.
Sums region_ref(const Image<std::uint32_t>& in, const CrossArms& a, PassOrder order) {
  const int w = in.width(), h = in.height();
  Sums out(static_cast<std::size_t>(w) * h, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      std::uint64_t s = 0;
      if (order == PassOrder::kHorizontalFirst) {
        for (int j = y - a.up.at(x, y); j <= y + a.down.at(x, y); ++j)
          for (int i = x - a.left.at(x, j); i <= x + a.right.at(x, j); ++i) s += in.at(i, j);
      } else {
        for (int i = x - a.left.at(x, y); i <= x + a.right.at(x, y); ++i)
          for (int j = y - a.up.at(i, y); j <= y + a.down.at(i, y); ++j) s += in.at(i, j);
      }
      out[y * w + x] = s;
    }
  return out;
}

Image<std::uint32_t> ones(int w, int h) {
  Image<std::uint32_t> img(w, h);
  img.fill(1);
  return img;
}

// Rounded mean of the brute-force region: the reference for SupportRegions::mean.
Image<std::uint32_t> mean_ref(const Image<std::uint32_t>& in, const CrossArms& a, PassOrder order) {
  const Sums s = region_ref(in, a, order);
  const Sums n = region_ref(ones(in.width(), in.height()), a, order);
  Image<std::uint32_t> out(in.width(), in.height());
  for (int y = 0; y < in.height(); ++y)
    for (int x = 0; x < in.width(); ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * in.width() + x;
      out.at(x, y) = static_cast<std::uint32_t>(std::llround(double(s[i]) / double(n[i])));
    }
  return out;
}

int max_abs_diff(const Image<std::uint32_t>& a, const Image<std::uint32_t>& b) {
  int m = 0;
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x)
      m = std::max<int>(m, std::abs(std::int64_t{a.at(x, y)} - std::int64_t{b.at(x, y)}));
  return m;
}

TEST(HorizontalSums, MatchBruteForceIncludingWrapAround) {
  std::mt19937 rng(1);
  std::vector<std::uint32_t> prefix;  // reused across sizes, grows as needed
  for (auto [w, h, max_arm, max_value] : {std::tuple{1, 1, 5, 1000u},
                                          {9, 4, 3, 1000u},
                                          {150, 7, 10, 200000000u},
                                          {300, 3, 255, 10000000u}}) {
    const auto in = test::random_image<std::uint32_t>(rng, w, h, 1, 0, max_value);
    const CrossArms a = test::random_arms(rng, w, h, max_arm);
    Image<std::uint32_t> out(w, h);
    horizontal_sums(in.view(), a.left.view(), a.right.view(), out.view(), prefix);
    EXPECT_GE(prefix.size(), static_cast<std::size_t>(w) + 1);
    const Sums ref = hsum_ref(in, a);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        ASSERT_LT(ref[y * w + x], std::uint64_t{1} << 32);  // the premise: true sums fit
        ASSERT_EQ(out.at(x, y), ref[y * w + x]) << w << "x" << h << " at " << x << "," << y;
      }
  }
}

TEST(VerticalSums, MatchBruteForceIncludingWrapAround) {
  std::mt19937 rng(2);
  for (auto [w, h, max_arm, max_value] : {std::tuple{1, 1, 5, 1000u},
                                          {4, 9, 3, 1000u},
                                          {7, 150, 10, 200000000u},
                                          {3, 300, 255, 10000000u}}) {
    const auto in = test::random_image<std::uint32_t>(rng, w, h, 1, 0, max_value);
    const CrossArms a = test::random_arms(rng, w, h, max_arm);
    Image<std::uint32_t> work = in;  // overwritten with running column sums
    Image<std::uint32_t> out(w, h);
    vertical_sums(work.view(), a.up.view(), a.down.view(), out.view());
    const Sums ref = vsum_ref(in, a);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        ASSERT_LT(ref[y * w + x], std::uint64_t{1} << 32);
        ASSERT_EQ(out.at(x, y), ref[y * w + x]) << w << "x" << h << " at " << x << "," << y;
      }
  }
}

TEST(HorizontalSums, ZeroArmsCopyTheInput) {
  std::mt19937 rng(3);
  const auto in = test::random_image<std::uint32_t>(rng, 11, 5, 1, 0, 0xffffffffu);
  CrossArms a;
  a.resize(11, 5);
  for (auto* arm : {&a.left, &a.right, &a.up, &a.down}) arm->fill(0);
  Image<std::uint32_t> out(11, 5);
  std::vector<std::uint32_t> prefix;
  horizontal_sums(in.view(), a.left.view(), a.right.view(), out.view(), prefix);
  EXPECT_EQ(max_abs_diff(in, out), 0);
  Image<std::uint32_t> work = in;
  vertical_sums(work.view(), a.up.view(), a.down.view(), out.view());
  EXPECT_EQ(max_abs_diff(in, out), 0);
}

TEST(SupportRegions, SizesMatchBruteForceCountsForBothOrders) {
  std::mt19937 rng(4);
  for (auto [w, h, max_arm] : {std::tuple{1, 1, 3}, {6, 5, 2}, {41, 29, 9}, {23, 37, 40}}) {
    const CrossArms a = test::random_arms(rng, w, h, max_arm);
    AggregationScratch scratch;
    SupportRegions regions;
    regions.build(a, scratch);
    EXPECT_EQ(&regions.arms(), &a);
    const Image<std::uint32_t> one = ones(w, h);
    for (PassOrder order : {PassOrder::kHorizontalFirst, PassOrder::kVerticalFirst}) {
      const Sums ref = region_ref(one, a, order);
      const auto sizes = regions.sizes(order);
      ASSERT_EQ(sizes.width, w);
      ASSERT_EQ(sizes.height, h);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) ASSERT_EQ(sizes.at(x, y), ref[y * w + x]) << x << "," << y;
    }
  }
}

TEST(SupportRegions, HandBuiltCrossHasTheExpectedSizes) {
  // 5x5, every pixel's arms 1 long where the image allows: p's region is the 3x3 block around it
  // (clipped at the border) in both orders.
  CrossArms a;
  a.resize(5, 5);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 5; ++x) {
      a.left.at(x, y) = x > 0;
      a.right.at(x, y) = x < 4;
      a.up.at(x, y) = y > 0;
      a.down.at(x, y) = y < 4;
    }
  // Centre pixel: a long horizontal arm only for itself (a "+" made asymmetric).
  a.left.at(2, 2) = 2;
  a.right.at(2, 2) = 2;
  AggregationScratch scratch;
  SupportRegions regions;
  regions.build(a, scratch);
  EXPECT_EQ(regions.sizes(PassOrder::kHorizontalFirst).at(1, 1), 9u);
  EXPECT_EQ(regions.sizes(PassOrder::kHorizontalFirst).at(0, 0), 4u);
  EXPECT_EQ(regions.sizes(PassOrder::kHorizontalFirst).at(4, 2), 6u);
  // Horizontal-first at the centre: rows 1 and 3 contribute 3 each, row 2 contributes 5.
  EXPECT_EQ(regions.sizes(PassOrder::kHorizontalFirst).at(2, 2), 11u);
  // Vertical-first at the centre: 5 columns of 3.
  EXPECT_EQ(regions.sizes(PassOrder::kVerticalFirst).at(2, 2), 15u);
  // Pixel (2, 1): horizontal-first sees the centre's long arm on its vertical arm.
  EXPECT_EQ(regions.sizes(PassOrder::kHorizontalFirst).at(2, 1), 3u + 3u + 5u);
  EXPECT_EQ(regions.sizes(PassOrder::kVerticalFirst).at(2, 1), 9u);
}

TEST(SupportRegions, SumMatchesBruteForceForBothOrders) {
  std::mt19937 rng(5);
  for (auto [w, h, max_arm, max_value] :
       {std::tuple{7, 3, 2, 4096u}, {50, 40, 10, 9000000u}, {33, 21, 255, 4096u}}) {
    const CrossArms a = test::random_arms(rng, w, h, max_arm);
    AggregationScratch scratch;
    SupportRegions regions;
    regions.build(a, scratch);
    const auto in = test::random_image<std::uint32_t>(rng, w, h, 1, 0, max_value);
    for (PassOrder order : {PassOrder::kHorizontalFirst, PassOrder::kVerticalFirst}) {
      Image<std::uint32_t> slice = in;
      regions.sum(slice.view(), order, scratch);
      const Sums ref = region_ref(in, a, order);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          ASSERT_LT(ref[y * w + x], std::uint64_t{1} << 32);
          ASSERT_EQ(slice.at(x, y), ref[y * w + x]) << x << "," << y;
        }
    }
  }
}

TEST(SupportRegions, MeanIsTheRoundedRegionMean) {
  std::mt19937 rng(6);
  for (auto [w, h, max_arm, max_value] :
       {std::tuple{9, 8, 3, 4097u}, {60, 45, 17, 4097u}, {40, 30, 34, 65534u}}) {
    const CrossArms a = test::random_arms(rng, w, h, max_arm);
    AggregationScratch scratch;
    SupportRegions regions;
    regions.build(a, scratch);
    const auto in = test::random_image<std::uint32_t>(rng, w, h, 1, 0, max_value);
    for (PassOrder order : {PassOrder::kHorizontalFirst, PassOrder::kVerticalFirst}) {
      Image<std::uint32_t> slice = in;
      regions.mean(slice.view(), order, scratch);
      EXPECT_LE(max_abs_diff(slice, mean_ref(in, a, order)), 1);
    }
  }
}

TEST(SupportRegions, MeanOfAConstantIsExact) {
  std::mt19937 rng(7);
  const CrossArms a = test::random_arms(rng, 37, 23, 34);
  AggregationScratch scratch;
  SupportRegions regions;
  regions.build(a, scratch);
  for (std::uint32_t v : {0u, 1u, 2047u, 4096u, 65535u}) {
    for (PassOrder order : {PassOrder::kHorizontalFirst, PassOrder::kVerticalFirst}) {
      Image<std::uint32_t> slice(37, 23);
      slice.fill(v);
      regions.mean(slice.view(), order, scratch);
      for (int y = 0; y < 23; ++y)
        for (int x = 0; x < 37; ++x) ASSERT_EQ(slice.at(x, y), v) << x << "," << y;
    }
  }
}

TEST(SupportRegions, SinglePixelRegionsLeaveValuesUnchanged) {
  std::mt19937 rng(8);
  CrossArms a;
  a.resize(13, 6);
  for (auto* arm : {&a.left, &a.right, &a.up, &a.down}) arm->fill(0);
  AggregationScratch scratch;
  SupportRegions regions;
  regions.build(a, scratch);
  const auto in = test::random_image<std::uint32_t>(rng, 13, 6, 1, 0, 0xffffffffu);
  Image<std::uint32_t> slice = in;
  regions.mean(slice.view(), PassOrder::kHorizontalFirst, scratch);
  EXPECT_EQ(max_abs_diff(slice, in), 0);
  regions.mean(slice.view(), PassOrder::kVerticalFirst, scratch);
  EXPECT_EQ(max_abs_diff(slice, in), 0);
}

TEST(AggregateCosts, AlternatesHorizontalFirstAndVerticalFirstMeans) {
  std::mt19937 rng(9);
  const int w = 48, h = 36;
  const CrossArms a = test::random_arms(rng, w, h, 12);
  AggregationScratch scratch;
  SupportRegions regions;
  regions.build(a, scratch);
  const auto in = test::random_image<std::uint32_t>(rng, w, h, 1, 0, 4097);

  Image<std::uint32_t> zero = in;
  aggregate_costs(zero.view(), regions, 0, scratch);
  EXPECT_EQ(max_abs_diff(zero, in), 0);

  Image<std::uint32_t> one = in;
  aggregate_costs(one.view(), regions, 1, scratch);
  const auto ref_hv = mean_ref(in, a, PassOrder::kHorizontalFirst);
  EXPECT_LE(max_abs_diff(one, ref_hv), 1);
  // The first pass is horizontal-first: on random arms the other order is clearly different.
  EXPECT_GT(max_abs_diff(one, mean_ref(in, a, PassOrder::kVerticalFirst)), 1);

  Image<std::uint32_t> two = in;
  aggregate_costs(two.view(), regions, 2, scratch);
  // Pass two is the vertical-first mean of pass one's output...
  EXPECT_LE(max_abs_diff(two, mean_ref(one, a, PassOrder::kVerticalFirst)), 1);
  // ...and within rounding of the two exact passes.
  EXPECT_LE(max_abs_diff(two, mean_ref(ref_hv, a, PassOrder::kVerticalFirst)), 2);

  Image<std::uint32_t> three = in;
  aggregate_costs(three.view(), regions, 3, scratch);
  EXPECT_LE(max_abs_diff(three, mean_ref(two, a, PassOrder::kHorizontalFirst)), 1);

  // Same inputs, same scratch: bit-identical results.
  Image<std::uint32_t> again = in;
  aggregate_costs(again.view(), regions, 2, scratch);
  EXPECT_EQ(max_abs_diff(again, two), 0);
}

TEST(AggregateCosts, FlatCostsStayFlatAndAnIsolatedPeakSpreads) {
  const int w = 15, h = 15;
  const CrossArms a = test::full_arms(w, h);  // every region is the whole image
  AggregationScratch scratch;
  SupportRegions regions;
  regions.build(a, scratch);
  EXPECT_EQ(regions.sizes(PassOrder::kHorizontalFirst).at(7, 7), 225u);
  EXPECT_EQ(regions.sizes(PassOrder::kVerticalFirst).at(0, 14), 225u);
  Image<std::uint32_t> slice(w, h);
  slice.fill(0);
  slice.at(3, 9) = 225 * 100;
  aggregate_costs(slice.view(), regions, 2, scratch);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) ASSERT_EQ(slice.at(x, y), 100u);
}

}  // namespace
}  // namespace dco::stereo
