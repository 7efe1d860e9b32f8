#include "dco/pipeline/stereo/matching_cost.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "dco/pipeline/stereo/census.hpp"
#include "pipeline_test_support.hpp"

namespace dco::stereo {
namespace {

double alpha_of(const CostModel& m, int arm) {
  return 1.0 - std::exp(-m.gamma_l / (arm + m.epsilon));
}

TEST(AdWeight, FollowsEquationOneAndFallsWithArmLength) {
  const CostModel m;  // gamma 1, epsilon 0.8
  EXPECT_NEAR(ad_weight(m, 0), 1.0 - std::exp(-1.0 / 0.8), 1e-12);
  EXPECT_NEAR(ad_weight(m, 0), 0.71350, 1e-5);
  EXPECT_NEAR(ad_weight(m, 17), 1.0 - std::exp(-1.0 / 17.8), 1e-12);
  for (int arm = 0; arm <= 255; ++arm) {
    EXPECT_NEAR(ad_weight(m, arm), alpha_of(m, arm), 1e-12) << arm;
    EXPECT_GT(ad_weight(m, arm), 0.0);
    EXPECT_LT(ad_weight(m, arm), 1.0);
    if (arm > 0) {
      EXPECT_LT(ad_weight(m, arm), ad_weight(m, arm - 1)) << arm;
    }
  }
  CostModel custom{10.0, 40.0, 3.0, 0.5};
  EXPECT_NEAR(ad_weight(custom, 4), 1.0 - std::exp(-3.0 / 4.5), 1e-12);
  custom.gamma_l = 0.0;  // no edge control: census only
  EXPECT_EQ(ad_weight(custom, 4), 0.0);
}

TEST(CostTables, EntriesAreRoundedFixedPointEquationOne) {
  const CostModel m{7.0, 25.0, 2.0, 0.3};
  for (int channels : {1, 3}) {
    CostTables t;
    t.build(m, channels, 6);
    EXPECT_EQ(t.channels(), channels);
    EXPECT_EQ(t.max_arm(), 6);
    for (int arm = 0; arm <= 6; ++arm) {
      const double a = alpha_of(m, arm);
      for (int s = 0; s <= 255 * channels; ++s) {
        const double c_ad = double(s) / channels;  // mean absolute difference over channels
        ASSERT_EQ(t.ad_row(arm)[s], std::lround(4096.0 * a * (1.0 - std::exp(-c_ad / 7.0))))
            << "arm " << arm << " ad sum " << s;
      }
      for (int hd = 0; hd <= 64; ++hd)
        ASSERT_EQ(t.census_row(arm)[hd],
                  std::lround(4096.0 * (1.0 - a) * (1.0 - std::exp(-hd / 25.0))))
            << "arm " << arm << " hamming " << hd;
      EXPECT_EQ(t.ad_row(arm)[0], 0);
      EXPECT_EQ(t.census_row(arm)[0], 0);
      // Both terms grow with their distance, and their sum stays within one unit of cost.
      for (int s = 1; s <= 255 * channels; ++s) ASSERT_GE(t.ad_row(arm)[s], t.ad_row(arm)[s - 1]);
      for (int hd = 1; hd <= 64; ++hd) ASSERT_GE(t.census_row(arm)[hd], t.census_row(arm)[hd - 1]);
      EXPECT_LE(t.ad_row(arm)[255 * channels] + t.census_row(arm)[64], int(kCostScale) + 1);
    }
  }
}

// The kernel clamps AD indices to ad_flat_from: every arm's row must be constant from there on,
// and the bound must be tight (some row changes just before it), or costs would be wrong or the
// register lookup needlessly off. With the default model grey rows saturate within six vectors.
TEST(CostTables, AdRowsAreConstantFromTheAdvertisedIndex) {
  for (const CostModel m : {CostModel{}, CostModel{7.0, 25.0, 2.0, 0.3}})
    for (int channels : {1, 3}) {
      CostTables t;
      t.build(m, channels, 17);
      const kernels::CostTableView v = t.wide();
      ASSERT_GT(v.ad_flat_from, 0);
      bool changes_before = false;
      for (int arm = 0; arm <= 17; ++arm) {
        const std::uint16_t* row = t.ad_row(arm);
        for (int s = v.ad_flat_from; s < v.ad_size; ++s)
          ASSERT_EQ(row[s], row[v.ad_size - 1]) << "arm " << arm << " index " << s;
        changes_before = changes_before || row[v.ad_flat_from - 1] != row[v.ad_size - 1];
      }
      EXPECT_TRUE(changes_before) << channels << " channels";
      if (channels == 1 && m.lambda_ad == CostModel{}.lambda_ad) {
        EXPECT_LT(v.ad_flat_from, 96);
      }
    }
}

TEST(CostTables, LongerArmsShiftWeightFromAdToCensus) {
  CostTables t;
  t.build(CostModel{}, 1, 34);
  EXPECT_GT(t.ad_row(0)[40], t.ad_row(34)[40]);
  EXPECT_LT(t.census_row(0)[20], t.census_row(34)[20]);
  // Rebuilding with other parameters replaces the tables.
  t.build(CostModel{}, 3, 2);
  EXPECT_EQ(t.channels(), 3);
  EXPECT_EQ(t.max_arm(), 2);
  EXPECT_EQ(t.ad_row(2)[3 * 255],
            std::lround(4096.0 * alpha_of(CostModel{}, 2) * (1.0 - std::exp(-25.5))));
}

struct SliceInputs {
  Image<std::uint8_t> left, right, arm;
  Image<std::uint64_t> census_left, census_right;
};

Image<std::uint32_t> slice_at(const SliceInputs& in, const CostTables& t, int d) {
  Image<std::uint32_t> out(in.left.width(), in.left.height());
  out.fill(0xffffffffu);
  compute_cost_slice(in.left.view(), in.right.view(), in.census_left.view(), in.census_right.view(),
                     in.arm.view(), t, d, out.view());
  return out;
}

TEST(ComputeCostSlice, HandComputedPixelUsesItsOwnShortestArm) {
  const CostModel m;
  CostTables t;
  t.build(m, 3, 5);
  SliceInputs in;
  in.left = Image<std::uint8_t>(4, 1, 3);
  in.right = Image<std::uint8_t>(4, 1, 3);
  in.left.fill(0);
  in.right.fill(0);
  in.census_left = Image<std::uint64_t>(4, 1);
  in.census_right = Image<std::uint64_t>(4, 1);
  in.census_left.fill(0);
  in.census_right.fill(0);
  in.arm = Image<std::uint8_t>(4, 1);
  in.arm.fill(0);
  // Left pixel 3 against right pixel 3 - 2 = 1.
  const int l[3] = {10, 20, 30}, r[3] = {13, 20, 27};
  for (int c = 0; c < 3; ++c) {
    in.left.at(3, 0, c) = static_cast<std::uint8_t>(l[c]);
    in.right.at(1, 0, c) = static_cast<std::uint8_t>(r[c]);
  }
  in.census_left.at(3, 0) = 0b1011;
  in.census_right.at(1, 0) = 0b0001;  // Hamming distance 2
  in.arm.at(3, 0) = 4;
  const auto out = slice_at(in, t, 2);
  const double a = alpha_of(m, 4);
  const long expected = std::lround(4096.0 * a * (1.0 - std::exp(-(6.0 / 3.0) / 10.0))) +
                        std::lround(4096.0 * (1.0 - a) * (1.0 - std::exp(-2.0 / 40.0)));
  EXPECT_EQ(out.at(3, 0), expected);
  EXPECT_EQ(out.at(3, 0), std::uint32_t(t.ad_row(4)[6]) + t.census_row(4)[2]);
  // Pixel 2 against right pixel 0: identical (all zero) -> no cost.
  EXPECT_EQ(out.at(2, 0), 0u);
  // Pixels 0 and 1 have no partner at d = 2.
  EXPECT_EQ(out.at(0, 0), kCostScale);
  EXPECT_EQ(out.at(1, 0), kCostScale);
}

SliceInputs shifted_texture(std::mt19937& rng, int w, int h, int channels, int shift, int max_arm) {
  SliceInputs in;
  in.left = test::random_image<std::uint8_t>(rng, w, h, channels, 0, 255);
  in.right = Image<std::uint8_t>(w, h, channels);
  // left(x) = right(x - shift): the right image is the left one moved `shift` pixels left.
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < channels; ++c)
        in.right.at(x, y, c) = in.left.at(std::min(x + shift, w - 1), y, c);
  Image<std::uint8_t> gl(w, h), gr(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      gl.at(x, y) = in.left.at(x, y, 0);
      gr.at(x, y) = in.right.at(x, y, 0);
    }
  in.census_left = Image<std::uint64_t>(w, h);
  in.census_right = Image<std::uint64_t>(w, h);
  census_transform(gl.view(), 9, 7, in.census_left.view());
  census_transform(gr.view(), 9, 7, in.census_right.view());
  in.arm = test::random_image<std::uint8_t>(rng, w, h, 1, 0, static_cast<std::uint8_t>(max_arm));
  return in;
}

TEST(ComputeCostSlice, PixelsWithoutPartnerGetTheLargestCost) {
  std::mt19937 rng(3);
  CostTables t;
  t.build(CostModel{}, 1, 10);
  const SliceInputs in = shifted_texture(rng, 30, 4, 1, 0, 10);
  for (int d : {0, 1, 7, 29, 30, 45}) {
    const auto out = slice_at(in, t, d);
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 30; ++x) {
        if (x < d) {
          ASSERT_EQ(out.at(x, y), kCostScale) << "d " << d << " x " << x;
        } else {
          ASSERT_LE(out.at(x, y), kCostScale + 1) << "d " << d << " x " << x;
        }
      }
  }
}

TEST(ComputeCostSlice, IdenticalPixelsCostNothing) {
  std::mt19937 rng(11);
  for (int channels : {1, 3}) {
    CostTables t;
    t.build(CostModel{}, channels, 17);
    const SliceInputs in = shifted_texture(rng, 25, 6, channels, 0, 17);
    const auto out = slice_at(in, t, 0);
    for (int y = 0; y < 6; ++y)
      for (int x = 0; x < 25; ++x) ASSERT_EQ(out.at(x, y), 0u) << x << "," << y;
    // A constant image costs nothing at any disparity where a partner exists.
    SliceInputs flat = in;
    flat.left.fill(90);
    flat.right.fill(90);
    flat.census_left.fill(0);
    flat.census_right.fill(0);
    const auto out5 = slice_at(flat, t, 5);
    for (int x = 5; x < 25; ++x) EXPECT_EQ(out5.at(x, 3), 0u);
  }
}

TEST(ComputeCostSlice, ShiftedTextureHasItsMinimumAtTheTrueShift) {
  std::mt19937 rng(2024);
  const int w = 64, h = 12, shift = 9, max_d = 20;
  for (int channels : {1, 3}) {
    CostTables t;
    t.build(CostModel{}, channels, 34);
    const SliceInputs in = shifted_texture(rng, w, h, channels, shift, 34);
    std::vector<Image<std::uint32_t>> slices;
    for (int d = 0; d <= max_d; ++d) slices.push_back(slice_at(in, t, d));
    // Where neither census window reaches a border the true shift costs exactly 0 and, but for
    // rare coincidences (two equal local extrema), every other disparity costs more.
    long pixels = 0, unique = 0;
    for (int y = 0; y < h; ++y)
      for (int x = max_d + 4; x + 4 + shift < w; ++x) {
        ASSERT_EQ(slices[shift].at(x, y), 0u) << x << "," << y;
        bool alone = true;
        for (int d = 0; d <= max_d; ++d) alone = alone && (d == shift || slices[d].at(x, y) > 0);
        ++pixels;
        unique += alone;
      }
    EXPECT_GT(pixels, 300);
    EXPECT_GE(unique, pixels * 99 / 100) << channels << " channels";
  }
}

TEST(ComputeCostSlice, WritesOnlyIntoTheOutputView) {
  std::mt19937 rng(8);
  CostTables t;
  t.build(CostModel{}, 1, 34);
  const SliceInputs in = shifted_texture(rng, 16, 5, 1, 2, 34);
  Image<std::uint32_t> big(20, 9);
  big.fill(7);
  compute_cost_slice(in.left.view(), in.right.view(), in.census_left.view(), in.census_right.view(),
                     in.arm.view(), t, 2, big.view().sub(2, 2, 16, 5));
  const auto ref = slice_at(in, t, 2);
  for (int y = 0; y < 9; ++y)
    for (int x = 0; x < 20; ++x) {
      const bool inside = x >= 2 && x < 18 && y >= 2 && y < 7;
      ASSERT_EQ(big.at(x, y), inside ? ref.at(x - 2, y - 2) : 7u) << x << "," << y;
    }
}

}  // namespace
}  // namespace dco::stereo
