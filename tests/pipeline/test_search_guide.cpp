#include "dco/pipeline/stereo/search_guide.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "dco/core/image.hpp"

namespace dco::stereo {
namespace {

constexpr float kNone = std::numeric_limits<float>::infinity();

// A coarse map of `height` rows, 10 columns, every value `v` (kNone: no value).
Image<float> coarse_map(int height, float v) {
  Image<float> m(10, height);
  m.fill(v);
  return m;
}

TEST(SearchGuide, EachRowSearchesTheBatchesNearItsCoarseValues) {
  // Coarse rows 0..9 hold 10 (internal 20), rows 10..19 hold 30 (internal 60).
  Image<float> coarse = coarse_map(20, 10.0f);
  for (int y = 10; y < 20; ++y)
    for (int x = 0; x < 10; ++x) coarse.at(x, y) = 30.0f;
  GuideRule rule;
  rule.margin = 3;
  rule.reach = 2;  // one coarse row
  GuideScratch scratch;
  BatchMask mask;
  guide_batches(coarse.cview(), 20, 40, 100, rule, scratch, mask);
  ASSERT_EQ(mask.height(), 40);
  ASSERT_EQ(mask.batches(), 7);  // 0..100 in batches of 16
  // Internal row 4 (coarse row 2): 17..23, batch 1 only.
  for (int b = 0; b < 7; ++b) EXPECT_EQ(mask.searches(4, b), b == 1) << b;
  // Internal row 30 (coarse 15): 57..63, batch 3 only.
  for (int b = 0; b < 7; ++b) EXPECT_EQ(mask.searches(30, b), b == 3) << b;
  // Internal row 19 (coarse 9) reaches coarse row 10: both.
  for (int b = 0; b < 7; ++b) EXPECT_EQ(mask.searches(19, b), b == 1 || b == 3) << b;
  // Rows 18..21 take in coarse rows 9 and 10.
  EXPECT_NEAR(mask.searched_fraction(), (40.0 + 4.0) / (40.0 * 7.0), 1e-9);
}

TEST(SearchGuide, AMarginAcrossABatchEdgeTakesBothBatches) {
  const Image<float> coarse = coarse_map(4, 8.25f);  // internal 16.5: 15..18 with margin 1
  GuideRule rule;
  rule.margin = 1;
  GuideScratch scratch;
  BatchMask mask;
  guide_batches(coarse.cview(), 20, 8, 40, rule, scratch, mask);
  for (int y = 0; y < 8; ++y)
    for (int b = 0; b < 3; ++b) EXPECT_EQ(mask.searches(y, b), b <= 1) << y << "," << b;
}

TEST(SearchGuide, ValuesPastTheSearchTakeItsLastBatches) {
  // max_d 40 (batches 0..2): coarse 19.5 is internal 39..39 +- margin, the last two batches with
  // a margin of 9; 1e30 and the largest float reach only past the search, so the last batch, as
  // does 21 (internal 42); a wide margin (60) reaches back to batch 0 from 21 but not from 1e30.
  for (const float v : {19.5f, 21.0f, 1e30f, std::numeric_limits<float>::max()})
    for (const int margin : {9, 60}) {
      const Image<float> coarse = coarse_map(4, v);
      GuideRule rule;
      rule.margin = margin;
      GuideScratch scratch;
      BatchMask mask;
      guide_batches(coarse.cview(), 20, 8, 40, rule, scratch, mask);
      const int d_lo = std::clamp(static_cast<int>(std::min(2.0f * v, 1e9f)) - margin, 0, 40);
      for (int b = 0; b < 3; ++b)
        EXPECT_EQ(mask.searches(3, b), b >= d_lo / 16) << v << " margin " << margin << " " << b;
    }
}

TEST(SearchGuide, RowsWithTooFewCoarseValuesSearchEverything) {
  // Rows 0..5 have no value at all, rows 6..11 one value in ten (below 20 %), the rest all.
  Image<float> coarse = coarse_map(24, 5.0f);
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 10; ++x) coarse.at(x, y) = y >= 6 && x == 0 ? 5.0f : kNone;
  coarse.at(3, 2) = std::numeric_limits<float>::quiet_NaN();
  coarse.at(4, 2) = -1.0f;
  GuideRule rule;
  rule.reach = 0;
  rule.min_valid = 0.2;
  GuideScratch scratch;
  BatchMask mask;
  guide_batches(coarse.cview(), 20, 48, 60, rule, scratch, mask);
  for (int b = 0; b < 4; ++b) {
    EXPECT_TRUE(mask.searches(2, b));              // coarse row 1: nothing
    EXPECT_TRUE(mask.searches(14, b));             // coarse row 7: 10 %
    EXPECT_EQ(mask.searches(40, b), b <= 1) << b;  // coarse row 20: 10 +- 12 = 0..22
  }
}

TEST(SearchGuide, ReusedScratchGivesTheSameMask) {
  const Image<float> wide = coarse_map(30, 20.0f), narrow = coarse_map(6, 2.0f);
  GuideScratch scratch;
  BatchMask first, again, other;
  guide_batches(wide.cview(), 20, 60, 120, GuideRule{}, scratch, first);
  guide_batches(narrow.cview(), 20, 12, 30, GuideRule{}, scratch, other);
  guide_batches(wide.cview(), 20, 60, 120, GuideRule{}, scratch, again);
  for (int y = 0; y < 60; ++y)
    for (int b = 0; b < first.batches(); ++b)
      ASSERT_EQ(first.tile_bits(y, b), again.tile_bits(y, b));
}

// 40 coarse columns (80 internal) in tiles of 16: the left half holds 10 (internal 20), the right
// half 30 (internal 60).
Image<float> two_halves(int height) {
  Image<float> m(40, height);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < 40; ++x) m.at(x, y) = x < 20 ? 10.0f : 30.0f;
  return m;
}

// Tiles of 16 internal columns that take in only their own coarse values, margin 3.
GuideRule own_tiles_of_16() {
  GuideRule rule;
  rule.margin = 3;
  rule.tile = 16;
  rule.tile_margin = 0;
  return rule;
}

TEST(SearchGuide, EachTileSearchesTheBatchesNearItsOwnValues) {
  const Image<float> coarse = two_halves(10);
  GuideRule rule = own_tiles_of_16();
  GuideScratch scratch;
  BatchMask mask;
  guide_batches(coarse.cview(), 80, 20, 100, rule, scratch, mask);
  ASSERT_EQ(mask.tiles(), 5);
  ASSERT_EQ(mask.tile_width(), 16);
  for (int y = 0; y < 20; ++y) {
    for (int b = 0; b < 7; ++b) {
      // Tiles 0 and 1 (internal columns 0..31): 17..23, batch 1; tiles 3 and 4: 57..63, batch 3;
      // tile 2 (columns 32..47, coarse 16..23) holds both.
      EXPECT_EQ(mask.searches(y, 0, b), b == 1) << y << "," << b;
      EXPECT_EQ(mask.searches(y, 1, b), b == 1) << y << "," << b;
      EXPECT_EQ(mask.searches(y, 2, b), b == 1 || b == 3) << y << "," << b;
      EXPECT_EQ(mask.searches(y, 3, b), b == 3) << y << "," << b;
      EXPECT_EQ(mask.searches(y, 4, b), b == 3) << y << "," << b;
      EXPECT_EQ(mask.searches(y, b), b == 1 || b == 3) << y << "," << b;
    }
  }
  // Six of the 35 (tile, batch) pairs of every row, each 16 columns wide.
  EXPECT_NEAR(mask.searched_fraction(), 6.0 / 35.0, 1e-9);
  // A tile margin reaching across the middle takes the other half's batch in too.
  rule.tile_margin = 10;
  guide_batches(coarse.cview(), 80, 20, 100, rule, scratch, mask);
  for (int b = 0; b < 7; ++b) {
    EXPECT_EQ(mask.searches(0, 1, b), b == 1 || b == 3) << b;  // columns 6..41: coarse 3..20
    EXPECT_EQ(mask.searches(0, 0, b), b == 1) << b;            // columns 0..25: coarse 0..12
  }
}

TEST(SearchGuide, ATileWithTooFewValuesTakesItsRowsBatches) {
  Image<float> coarse = two_halves(10);
  // Tile 4 (coarse columns 32..39): one value in four, below the tile's share; the row keeps
  // enough.
  for (int y = 0; y < 10; ++y)
    for (int x = 32; x < 40; ++x)
      if (x % 4 != 0) coarse.at(x, y) = kNone;
  GuideRule rule = own_tiles_of_16();
  rule.tile_min_valid = 0.5;
  GuideScratch scratch;
  BatchMask mask;
  guide_batches(coarse.cview(), 80, 20, 100, rule, scratch, mask);
  for (int b = 0; b < 7; ++b) {
    EXPECT_EQ(mask.searches(5, 4, b), b == 1 || b == 3) << b;
    EXPECT_EQ(mask.searches(5, 3, b), b == 3) << b;
  }
  // With a share the tile meets, its own values rule.
  rule.tile_min_valid = 0.2;
  guide_batches(coarse.cview(), 80, 20, 100, rule, scratch, mask);
  for (int b = 0; b < 7; ++b) EXPECT_EQ(mask.searches(5, 4, b), b == 3) << b;
}

TEST(SearchGuide, TilesWidenSoARowNeedsAtMostSixtyFour) {
  const Image<float> coarse = coarse_map(4, 5.0f);
  GuideRule rule;
  rule.tile = 8;
  GuideScratch scratch;
  BatchMask mask;
  guide_batches(coarse.cview(), 1000, 8, 40, rule, scratch, mask);
  EXPECT_EQ(mask.tile_width(), 16);  // ceil(1000 / 64)
  EXPECT_EQ(mask.tiles(), 63);
  EXPECT_EQ(mask.searches(3, 62, 0), true);
}

TEST(BatchMask, TilesCoverTheWidthAndWeighTheLastByItsColumns) {
  BatchMask mask;
  mask.reset(2, 1, false, 40, 16);  // tiles of 16, 16 and 8 columns
  ASSERT_EQ(mask.tiles(), 3);
  mask.set(0, 2, 0);
  EXPECT_NEAR(mask.searched_fraction(), 8.0 / 80.0, 1e-12);
  mask.set(1, 0);  // every tile of row 1
  EXPECT_NEAR(mask.searched_fraction(), 48.0 / 80.0, 1e-12);
  EXPECT_EQ(mask.tile_bits(1, 0), 7u);
  EXPECT_THROW(mask.reset(2, 1, false, 65 * 4, 4), Error);
  EXPECT_THROW(mask.reset(2, 1, false, 40, 0), Error);
  mask.reset(2, 1, true, 64 * 4, 4);  // exactly 64 tiles
  EXPECT_EQ(mask.tile_bits(0, 0), ~std::uint64_t{0});
}

TEST(BatchMask, MergeSearchesWhatEitherSearches) {
  BatchMask a, b;
  a.reset(3, 2, false, 40, 16);
  b.reset(3, 2, false, 40, 16);
  a.set(0, 0, 1);
  b.set(0, 2, 1);
  b.set(2, 0);
  a.merge(b);
  EXPECT_EQ(a.tile_bits(0, 1), 5u);
  EXPECT_EQ(a.tile_bits(2, 0), 7u);
  EXPECT_EQ(a.tile_bits(1, 0) | a.tile_bits(1, 1) | a.tile_bits(0, 0), 0u);
  EXPECT_EQ(b.tile_bits(0, 1), 4u) << "the other mask is left as it was";
  BatchMask other_tiles;
  other_tiles.reset(3, 2, false, 40, 8);
  EXPECT_THROW(a.merge(other_tiles), Error);
  BatchMask other_batches;
  other_batches.reset(3, 3, false, 40, 16);
  EXPECT_THROW(a.merge(other_batches), Error);
}

TEST(SearchGuide, HalvedMapKeepsEachBlocksNearestSurfaceHalved) {
  // 5x5: the last row and column fall outside the 2x2 halved map.
  Image<float> map(5, 5);
  map.fill(kNone);
  map.at(0, 0) = 10.0f;  // block (0, 0): 10, 30 and junk -> 15
  map.at(1, 1) = 30.0f;
  map.at(1, 0) = std::numeric_limits<float>::quiet_NaN();
  map.at(0, 1) = -4.0f;
  map.at(2, 0) = 7.0f;   // block (1, 0): 7 -> 3.5
  map.at(4, 4) = 99.0f;  // outside
  map.at(4, 0) = 99.0f;
  Image<float> half(2, 2);
  halve_sparse_map(map.cview(), half.view());
  EXPECT_EQ(half.at(0, 0), 15.0f);
  EXPECT_EQ(half.at(1, 0), 3.5f);
  EXPECT_EQ(half.at(0, 1), kNone);  // only +inf there
  EXPECT_EQ(half.at(1, 1), kNone);
  Image<float> wrong(3, 2);
  EXPECT_THROW(halve_sparse_map(map.cview(), wrong.view()), Error);
}

// The mask straight from its definition (search_guide.hpp), one coarse value at a time: which
// batches tile t of internal row y searches.
std::vector<bool> reference_tile(ImageView<const float> coarse, int width, int max_d,
                                 const GuideRule& rule, int y, int t) {
  const int f = rule.scale;
  const int batches = max_d / rule.batch + 1;
  const int tile = std::max(rule.tile, (width + BatchMask::kMaxTiles - 1) / BatchMask::kMaxTiles);
  const int centre = std::min(y / f, coarse.height - 1);
  const int reach = (rule.reach + f - 1) / f;  // coarse rows that cover `reach` internal rows
  const int top = std::max(0, centre - reach);
  const int bottom = std::min(coarse.height, centre + reach + 1);
  const auto scan = [&](const std::vector<bool>& columns, std::vector<bool>& on) {
    int values = 0;
    for (int cy = top; cy < bottom; ++cy)
      for (int x = 0; x < coarse.width; ++x) {
        const float v = coarse.row(cy)[x];
        if (!columns[static_cast<std::size_t>(x)] || !std::isfinite(v) || v < 0) continue;
        ++values;
        const double scaled = f * std::min<double>(v, max_d + rule.margin + 1);
        const int lo = std::clamp(static_cast<int>(std::floor(scaled)) - rule.margin, 0, max_d);
        const int hi = std::clamp(static_cast<int>(std::ceil(scaled)) + rule.margin, 0, max_d);
        for (int d = lo; d <= hi; ++d) on[static_cast<std::size_t>(d / rule.batch)] = true;
      }
    return values;
  };
  const std::vector<bool> every(static_cast<std::size_t>(coarse.width), true);
  std::vector<bool> row(static_cast<std::size_t>(batches), false);
  const int row_values = scan(every, row);
  if (row_values < rule.min_valid * (bottom - top) * coarse.width)
    return std::vector<bool>(static_cast<std::size_t>(batches), true);
  // The tile's coarse columns: those with an internal column within tile_margin of the tile.
  std::vector<bool> columns(static_cast<std::size_t>(coarse.width), false);
  int taken = 0;
  for (int x = 0; x < coarse.width; ++x) {
    const bool near = f * x + f - 1 >= t * tile - rule.tile_margin &&
                      f * x <= (t + 1) * tile + rule.tile_margin - 1;
    columns[static_cast<std::size_t>(x)] = near;
    taken += near;
  }
  std::vector<bool> own(static_cast<std::size_t>(batches), false);
  const int own_values = scan(columns, own);
  return taken == 0 || own_values < rule.tile_min_valid * (bottom - top) * taken ? row : own;
}

TEST(SearchGuide, MatchesTheDefinitionOnRandomMaps) {
  std::mt19937 rng(7);
  GuideScratch scratch;  // reused across sizes and rules
  for (int trial = 0; trial < 60; ++trial) {
    const int cw = 3 + static_cast<int>(rng() % 60), ch = 2 + static_cast<int>(rng() % 30);
    GuideRule rule;
    rule.scale = 1 << (trial % 3);  // 1, 2 and 4
    const int f = rule.scale;
    const int width = f * cw + static_cast<int>(rng() % f),
              height = f * ch + static_cast<int>(rng() % f);
    const int max_d = static_cast<int>(rng() % 140);
    rule.batch = 1 + static_cast<int>(rng() % 16);
    rule.margin = static_cast<int>(rng() % 14);
    rule.reach = static_cast<int>(rng() % 9);
    rule.tile = 1 + static_cast<int>(rng() % 40);
    rule.tile_margin = static_cast<int>(rng() % 12);
    rule.min_valid = (rng() % 5) * 0.1;
    rule.tile_min_valid = (rng() % 8) * 0.1;
    Image<float> coarse(cw, ch);
    // Mostly smooth surfaces at a few depths, with holes, NaN, negative values and values past
    // the search.
    const float base = static_cast<float>(rng() % 80);
    for (int cy = 0; cy < ch; ++cy)
      for (int x = 0; x < cw; ++x) {
        const unsigned r = rng() % 20;
        float v = base + 0.37f * static_cast<float>(x % 17) + 0.5f * static_cast<float>(cy / 5);
        if (r == 0) v = kNone;
        if (r == 1) v = std::numeric_limits<float>::quiet_NaN();
        if (r == 2) v = -3.0f;
        if (r == 3) v = 1000.0f;
        if (r == 4) v = static_cast<float>(rng() % 1000) / 10.0f;
        coarse.at(x, cy) = v;
      }
    BatchMask mask;
    guide_batches(coarse.cview(), width, height, max_d, rule, scratch, mask);
    ASSERT_EQ(mask.batches(), max_d / rule.batch + 1);
    for (int y = 0; y < height; ++y)
      for (int t = 0; t < mask.tiles(); ++t) {
        const std::vector<bool> want = reference_tile(coarse.cview(), width, max_d, rule, y, t);
        for (int b = 0; b < mask.batches(); ++b)
          ASSERT_EQ(mask.searches(y, t, b), want[static_cast<std::size_t>(b)])
              << "trial " << trial << " row " << y << " tile " << t << " batch " << b;
      }
  }
}

TEST(SearchGuide, RejectsAnEmptyMapOrABadRule) {
  GuideScratch scratch;
  BatchMask mask;
  const Image<float> empty, coarse = coarse_map(4, 1.0f);
  EXPECT_THROW(guide_batches(empty.cview(), 20, 8, 40, GuideRule{}, scratch, mask), Error);
  GuideRule bad;
  bad.batch = 0;
  EXPECT_THROW(guide_batches(coarse.cview(), 20, 8, 40, bad, scratch, mask), Error);
  GuideRule no_tile;
  no_tile.tile = 0;
  EXPECT_THROW(guide_batches(coarse.cview(), 20, 8, 40, no_tile, scratch, mask), Error);
  GuideRule no_scale;
  no_scale.scale = 0;
  EXPECT_THROW(guide_batches(coarse.cview(), 20, 8, 40, no_scale, scratch, mask), Error);
  EXPECT_THROW(guide_batches(coarse.cview(), 20, 0, 40, GuideRule{}, scratch, mask), Error);
  EXPECT_THROW(guide_batches(coarse.cview(), 0, 8, 40, GuideRule{}, scratch, mask), Error);
}

}  // namespace
}  // namespace dco::stereo
