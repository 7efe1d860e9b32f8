#include "dco/pipeline/stereo/search_guide.hpp"

#include <cmath>
#include <limits>

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
  guide_batches(coarse.cview(), 40, 100, rule, scratch, mask);
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
  guide_batches(coarse.cview(), 8, 40, rule, scratch, mask);
  for (int y = 0; y < 8; ++y)
    for (int b = 0; b < 3; ++b) EXPECT_EQ(mask.searches(y, b), b <= 1) << y << "," << b;
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
  guide_batches(coarse.cview(), 48, 60, rule, scratch, mask);
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
  guide_batches(wide.cview(), 60, 120, GuideRule{}, scratch, first);
  guide_batches(narrow.cview(), 12, 30, GuideRule{}, scratch, other);
  guide_batches(wide.cview(), 60, 120, GuideRule{}, scratch, again);
  for (int y = 0; y < 60; ++y)
    for (int b = 0; b < first.batches(); ++b) ASSERT_EQ(first.searches(y, b), again.searches(y, b));
}

TEST(SearchGuide, RejectsAnEmptyMapOrABadRule) {
  GuideScratch scratch;
  BatchMask mask;
  const Image<float> empty, coarse = coarse_map(4, 1.0f);
  EXPECT_THROW(guide_batches(empty.cview(), 8, 40, GuideRule{}, scratch, mask), Error);
  GuideRule bad;
  bad.batch = 0;
  EXPECT_THROW(guide_batches(coarse.cview(), 8, 40, bad, scratch, mask), Error);
  EXPECT_THROW(guide_batches(coarse.cview(), 0, 40, GuideRule{}, scratch, mask), Error);
}

}  // namespace
}  // namespace dco::stereo
