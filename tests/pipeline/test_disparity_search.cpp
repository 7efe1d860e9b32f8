#include "dco/pipeline/stereo/disparity_search.hpp"

#include <algorithm>
#include <cstdint>
#include <random>
#include <string_view>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "dco/core/image.hpp"
#include "dco/kernels/stereo_kernels.hpp"
#include "dco/pipeline/row_team.hpp"
#include "dco/pipeline/stereo/census.hpp"
#include "dco/pipeline/stereo/cross_aggregation.hpp"
#include "dco/pipeline/stereo/cross_arms.hpp"
#include "dco/pipeline/stereo/disparity_selection.hpp"
#include "dco/pipeline/stereo/matching_cost.hpp"

namespace dco::stereo {
namespace {

// A random pair with flat patches (long, irregular arms) and noise; the right image is the left
// one shifted by `shift` plus noise, so the winners are not all alike.
struct Pair {
  Image<std::uint8_t> left, right, gray_left, gray_right;
  Image<std::uint32_t> packed_left, packed_right;
  Image<std::uint64_t> census_left, census_right;
  CrossArms arms;
  Image<std::uint8_t> shortest;
  CostTables tables;

  // flat: both images one grey level, so every disparity of a pixel costs the same and every
  // choice between them falls to the order the search takes them in.
  Pair(int w, int h, int channels, int arm_max, unsigned seed, bool flat = false) {
    std::mt19937 rng(seed);
    left.resize(w, h, channels);
    right.resize(w, h, channels);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < channels; ++c) {
          const int patch = ((x / 5) * 7 + (y / 3) * 13 + c * 29) % 256;
          left.at(x, y, c) =
              static_cast<std::uint8_t>(flat ? 100 : patch + static_cast<int>(rng() % 4));
        }
    constexpr int kShift = 3;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < channels; ++c)
          right.at(x, y, c) = static_cast<std::uint8_t>(
              flat ? 100
                   : std::min(255, left.at(std::min(x + kShift, w - 1), y, c) +
                                       static_cast<int>(rng() % 3)));
    gray_left.resize(w, h);
    gray_right.resize(w, h);
    packed_left.resize(w, h);
    packed_right.resize(w, h);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        gray_left.at(x, y) = left.at(x, y, 0);
        gray_right.at(x, y) = right.at(x, y, 0);
      }
      kernels::pack_pixels(left.row(y), channels, w, packed_left.row(y));
      kernels::pack_pixels(right.row(y), channels, w, packed_right.row(y));
    }
    census_left.resize(w, h);
    census_right.resize(w, h);
    census_transform(gray_left.cview(), 5, 3, census_left.view());
    census_transform(gray_right.cview(), 5, 3, census_right.view());
    compute_cross_arms(left.cview(), ArmRule{arm_max, arm_max / 2, 20, 6}, arms);
    shortest.resize(w, h);
    for (int y = 0; y < h; ++y) shortest_arm_row(arms, y, shortest.row(y));
    tables.build(CostModel{}, channels, arm_max);
  }

  MatchingImages images() const {
    return {packed_left.cview(), packed_right.cview(), census_left.cview(), census_right.cview(),
            shortest.cview()};
  }
};

TEST(DisparitySearch, PackedCrossArmsEqualTheScalarArms) {
  for (const int channels : {1, 3}) {
    for (const int w : {9, 40, 77}) {
      const Pair p(w, 23, channels, 12, 3u + static_cast<unsigned>(w));
      for (const ArmRule rule : {ArmRule{12, 6, 20, 6}, ArmRule{34, 17, 20, 6}}) {
        CrossArms expected, arms;
        compute_cross_arms(p.left.cview(), rule, expected);
        compute_cross_arms(p.packed_left.cview(), rule, arms);
        for (const auto member :
             {&CrossArms::left, &CrossArms::right, &CrossArms::up, &CrossArms::down})
          for (int y = 0; y < 23; ++y)
            for (int x = 0; x < w; ++x)
              ASSERT_EQ((arms.*member).at(x, y), (expected.*member).at(x, y))
                  << "channels " << channels << " width " << w << " at " << x << "," << y;
      }
    }
  }
}

TEST(DisparitySearch, PackedCostSliceEqualsTheScalarSlice) {
  for (const int channels : {1, 3}) {
    for (const int w : {9, 16, 45}) {
      const Pair p(w, 7, channels, 8, 11u + static_cast<unsigned>(w));
      Image<std::uint32_t> expected(w, 7), out(w, 7);
      for (const int d : {0, 1, 4, w - 1, w}) {
        compute_cost_slice(p.left.cview(), p.right.cview(), p.census_left.cview(),
                           p.census_right.cview(), p.shortest.cview(), p.tables, d,
                           expected.view());
        out.fill(0);
        compute_cost_slice_packed(p.packed_left.cview(), p.packed_right.cview(),
                                  p.census_left.cview(), p.census_right.cview(), p.shortest.cview(),
                                  p.tables, d, out.view());
        for (int y = 0; y < 7; ++y)
          for (int x = 0; x < w; ++x)
            ASSERT_EQ(out.at(x, y), expected.at(x, y)) << "channels " << channels << " width " << w
                                                       << " d " << d << " at " << x << "," << y;
      }
    }
  }
}

// Eq. 2 by definition: the mean over the cross-based region, summed pixel by pixel.
void brute_force_mean(ImageView<std::uint32_t> slice, const CrossArms& a, PassOrder order) {
  Image<std::uint32_t> in(slice.width, slice.height);
  in.copy_from(slice);
  for (int y = 0; y < slice.height; ++y)
    for (int x = 0; x < slice.width; ++x) {
      std::uint64_t sum = 0, n = 0;
      if (order == PassOrder::kHorizontalFirst) {
        for (int yy = y - a.up.at(x, y); yy <= y + a.down.at(x, y); ++yy)
          for (int xx = x - a.left.at(x, yy); xx <= x + a.right.at(x, yy); ++xx, ++n)
            sum += in.at(xx, yy);
      } else {
        for (int xx = x - a.left.at(x, y); xx <= x + a.right.at(x, y); ++xx)
          for (int yy = y - a.up.at(xx, y); yy <= y + a.down.at(xx, y); ++yy, ++n)
            sum += in.at(xx, yy);
      }
      const std::uint64_t recip = ((std::uint64_t{1} << 31) + n / 2) / n;
      slice.at(x, y) = static_cast<std::uint32_t>((sum * recip + (std::uint64_t{1} << 30)) >> 31);
    }
}

template <typename T>
void expect_same(ImageView<const T> a, ImageView<const T> b, const char* what) {
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x)
      ASSERT_EQ(a.row(y)[x], b.row(y)[x]) << what << " at " << x << "," << y;
}

// Disparity d's costs, aggregated over `passes` alternating passes by brute force.
void reference_slice(const Pair& p, int passes, int d, ImageView<std::uint32_t> slice) {
  compute_cost_slice(p.left.cview(), p.right.cview(), p.census_left.cview(), p.census_right.cview(),
                     p.shortest.cview(), p.tables, d, slice);
  for (int i = 0; i < passes; ++i)
    brute_force_mean(slice, p.arms,
                     i % 2 == 0 ? PassOrder::kHorizontalFirst : PassOrder::kVerticalFirst);
}

// Everything the checks after the search read.
void expect_same_state(const WinnerTakesAll& wta, const WinnerTakesAll& expected) {
  expect_same(wta.left_disparity(), expected.left_disparity(), "left disparity");
  expect_same(wta.right_disparity(), expected.right_disparity(), "right disparity");
  expect_same(wta.best_cost(), expected.best_cost(), "best cost");
  expect_same(wta.second_cost(), expected.second_cost(), "second cost");
  expect_same(wta.cost_below(), expected.cost_below(), "cost below");
  expect_same(wta.cost_above(), expected.cost_above(), "cost above");
}

TEST(DisparitySearch, EqualsCostAggregationAndWinnerTakesAllSliceBySlice) {
  for (const int channels : {1, 3}) {
    for (const int passes : {1, 2}) {
      const int w = 45, h = 17;
      const Pair p(w, h, channels, 7, 5u + static_cast<unsigned>(channels));
      AggregationScratch scratch;
      SupportRegions regions;
      regions.build(p.arms, scratch);
      // max_d near the width, and a count of disparities that is not a multiple of the batch.
      for (const int max_d : {0, 5, w - 1}) {
        WinnerTakesAll expected;
        expected.reset(w, h);
        Image<std::uint32_t> slice(w, h);
        for (int d = 0; d <= max_d; ++d) {
          reference_slice(p, passes, d, slice.view());
          expected.update(slice.cview(), d);
        }
        WinnerTakesAll wta;
        wta.reset(w, h);
        DisparitySearch search;
        search.run(p.images(), p.tables, regions, passes, max_d, wta);
        SCOPED_TRACE(testing::Message()
                     << "channels " << channels << " passes " << passes << " max_d " << max_d);
        expect_same_state(wta, expected);
      }
    }
  }
}

// Rows search random runs of batches: runs and gaps both shorter and longer than the arms'
// reach, so the fused search both joins runs and starts new ones mid-image.
BatchMask random_mask(int height, int batches, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> length(1, 20), coin(0, 1);
  BatchMask mask;
  mask.reset(height, batches, false);
  for (int b = 0; b < batches; ++b)
    for (int y = 0; y < height;) {
      const int n = length(rng);
      const bool on = coin(rng) != 0;
      for (int k = 0; k < n && y < height; ++k, ++y)
        if (on) mask.set(y, b);
    }
  return mask;
}

// The same per tile of `tile_width` columns: each tile's rows search random runs of batches.
BatchMask random_tiled_mask(int height, int batches, int width, int tile_width, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> length(1, 20), coin(0, 1);
  BatchMask mask;
  mask.reset(height, batches, false, width, tile_width);
  for (int b = 0; b < batches; ++b)
    for (int t = 0; t < mask.tiles(); ++t)
      for (int y = 0; y < height;) {
        const int n = length(rng);
        const bool on = coin(rng) != 0;
        for (int k = 0; k < n && y < height; ++k, ++y)
          if (on) mask.set(y, t, b);
      }
  return mask;
}

TEST(DisparitySearch, WithABatchMaskEqualsTheFullSearchWithTheOtherBatchesLeftOut) {
  for (const auto& [passes, flat] :
       {std::pair{1, false}, std::pair{2, false}, std::pair{1, true}}) {
    const int w = 52, h = 61;
    const Pair p(w, h, 3, 7, 11u, flat);
    AggregationScratch scratch;
    SupportRegions regions;
    regions.build(p.arms, scratch);
    const int max_d = 40;  // three batches, the last one partial
    const int batches = max_d / DisparitySearch::kBatch + 1;
    BatchMask all, none;
    all.reset(h, batches, true);
    none.reset(h, batches, false);
    // Tiles of 5 columns (narrower than the arms), of 13, and of 13 with the last one short.
    for (const auto& [name, mask] :
         {std::pair{"random 1", random_mask(h, batches, 1)},
          std::pair{"random 2", random_mask(h, batches, 2)}, std::pair{"all", all},
          std::pair{"none", none}, std::pair{"tiles of 5", random_tiled_mask(h, batches, w, 5, 4)},
          std::pair{"tiles of 13", random_tiled_mask(h, batches, w, 13, 5)},
          std::pair{"tiles of 26", random_tiled_mask(h, batches, w, 26, 6)}}) {
      // The full search's costs, kNoCost where the pixel's tile does not search the batch.
      WinnerTakesAll expected;
      expected.reset(w, h);
      Image<std::uint32_t> slice(w, h);
      std::vector<std::uint16_t> costs(static_cast<std::size_t>(w));
      for (int d = 0; d <= max_d; ++d) {
        reference_slice(p, passes, d, slice.view());
        for (int y = 0; y < h; ++y) {
          for (int x = 0; x < w; ++x)
            costs[x] = mask.searches(y, x / mask.tile_width(), d / DisparitySearch::kBatch)
                           ? static_cast<std::uint16_t>(slice.at(x, y))
                           : WinnerTakesAll::kNoCost;
          expected.update_row(costs.data(), 0, 1, y, d);
        }
      }
      WinnerTakesAll wta;
      wta.reset(w, h);
      DisparitySearch search;
      search.run(p.images(), p.tables, regions, passes, max_d, wta, &mask);
      SCOPED_TRACE(testing::Message()
                   << "passes " << passes << (flat ? ", flat" : "") << ", mask " << name);
      expect_same_state(wta, expected);
      if (std::string_view(name) == "all") {
        WinnerTakesAll unmasked;
        unmasked.reset(w, h);
        search.run(p.images(), p.tables, regions, passes, max_d, unmasked);
        expect_same(wta.left_disparity(), unmasked.left_disparity(), "all vs no mask");
        expect_same(wta.cost_above(), unmasked.cost_above(), "all vs no mask");
      }
    }
  }
}

// A team's threads each search a band of rows; every row's state is that of one thread's
// search, with and without a mask, for bands shorter and longer than the arms' reach.
TEST(DisparitySearch, BandsOfATeamGiveTheSearchOfOneThread) {
  const int w = 52, h = 61;
  const Pair p(w, h, 3, 7, 13u);
  AggregationScratch scratch;
  SupportRegions regions;
  regions.build(p.arms, scratch);
  const int max_d = 40;
  const int batches = max_d / DisparitySearch::kBatch + 1;
  const BatchMask mask = random_mask(h, batches, 3);
  const BatchMask tiled = random_tiled_mask(h, batches, w, 12, 7);
  for (const BatchMask* m : {static_cast<const BatchMask*>(nullptr), &mask, &tiled}) {
    WinnerTakesAll expected;
    expected.reset(w, h);
    DisparitySearch one;
    one.run(p.images(), p.tables, regions, 1, max_d, expected, m);
    for (const int threads : {2, 3, 4, 16}) {
      pipeline::RowTeam team(threads);
      DisparitySearch search;
      for (int frame = 0; frame < 2; ++frame) {
        WinnerTakesAll wta;
        wta.reset(w, h);
        search.run(p.images(), p.tables, regions, 1, max_d, wta, m, &team);
        SCOPED_TRACE(testing::Message()
                     << threads << " threads, frame " << frame << (m != nullptr ? ", masked" : ""));
        expect_same_state(wta, expected);
      }
    }
  }
}

TEST(DisparitySearch, RejectsAMaskThatDoesNotCoverTheSearch) {
  const Pair p(20, 9, 1, 5, 3u);
  AggregationScratch scratch;
  SupportRegions regions;
  regions.build(p.arms, scratch);
  WinnerTakesAll wta;
  wta.reset(20, 9);
  DisparitySearch search;
  BatchMask short_rows, few_batches, narrow;
  short_rows.reset(8, 2, true);
  few_batches.reset(9, 1, true);
  narrow.reset(9, 2, true, 16, 4);  // 16 of the 20 columns
  EXPECT_THROW(search.run(p.images(), p.tables, regions, 1, 17, wta, &short_rows), Error);
  EXPECT_THROW(search.run(p.images(), p.tables, regions, 1, 17, wta, &few_batches), Error);
  EXPECT_THROW(search.run(p.images(), p.tables, regions, 1, 17, wta, &narrow), Error);
  EXPECT_NO_THROW(search.run(p.images(), p.tables, regions, 1, 15, wta, &few_batches));
}

}  // namespace
}  // namespace dco::stereo
