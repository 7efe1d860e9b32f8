#include "dco/pipeline/stereo/histogram_vote.hpp"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "dco/pipeline/stereo/disparity_selection.hpp"
#include "pipeline_test_support.hpp"

namespace dco::stereo {
namespace {

constexpr std::int16_t kInv = kInvalidDisparity;

// Support regions over arms that outlive them.
class Regions {
 public:
  explicit Regions(CrossArms arms) : arms_(std::move(arms)) { regions_.build(arms_, scratch_); }
  Regions(const Regions&) = delete;
  Regions& operator=(const Regions&) = delete;
  const SupportRegions& get() const { return regions_; }

 private:
  CrossArms arms_;
  AggregationScratch scratch_;
  SupportRegions regions_;
};

// Arms that stay inside the column block [x0, x1) and the whole height: every region is that
// block.
CrossArms block_arms(int w, int h, const std::vector<std::pair<int, int>>& blocks) {
  CrossArms a = test::full_arms(w, h);
  for (auto [x0, x1] : blocks)
    for (int y = 0; y < h; ++y)
      for (int x = x0; x < x1; ++x) {
        a.left.at(x, y) = static_cast<std::uint8_t>(x - x0);
        a.right.at(x, y) = static_cast<std::uint8_t>(x1 - 1 - x);
      }
  return a;
}

// Regions of p = p's row, one pixel to either side.
CrossArms row_triplet_arms(int w, int h) {
  CrossArms a;
  a.resize(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      a.left.at(x, y) = x > 0;
      a.right.at(x, y) = x + 1 < w;
      a.up.at(x, y) = 0;
      a.down.at(x, y) = 0;
    }
  return a;
}

Image<std::int16_t> filled(int w, int h, int value) {
  Image<std::int16_t> img(w, h);
  img.fill(static_cast<std::int16_t>(value));
  return img;
}

std::vector<int> values(const Image<std::int16_t>& img) {
  std::vector<int> out;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) out.push_back(img.at(x, y));
  return out;
}

VoteRule rule_with(int iterations, int min_count, double min_ratio, int tolerance, bool fill) {
  VoteRule r;
  r.iterations = iterations;
  r.min_count = min_count;
  r.min_ratio = min_ratio;
  r.tolerance = tolerance;
  r.fill_invalid = fill;
  return r;
}

TEST(HistogramVote, MajorityReplacesOutliersBeyondTheTolerance) {
  const Regions regions(test::full_arms(7, 7));  // every region: all 49 pixels
  VoteScratch scratch;
  Image<std::uint8_t> changed(7, 7);
  changed.fill(7);  // cleared by the vote

  auto disp = filled(7, 7, 10);
  disp.at(3, 3) = 20;  // far outlier
  disp.at(1, 1) = 11;  // within tolerance 1: keeps its own value
  disp.at(5, 5) = 12;  // just beyond it
  auto d1 = disp;
  histogram_vote(d1.view(), 32, regions.get(), rule_with(1, 20, 0.4, 1, false), scratch,
                 changed.view());
  for (int y = 0; y < 7; ++y)
    for (int x = 0; x < 7; ++x) {
      const int expected = (x == 1 && y == 1) ? 11 : 10;
      ASSERT_EQ(d1.at(x, y), expected) << x << "," << y;
      const bool moved = (x == 3 && y == 3) || (x == 5 && y == 5);
      ASSERT_EQ(changed.at(x, y), moved ? 1 : 0) << x << "," << y;
    }

  auto d2 = disp;
  histogram_vote(d2.view(), 32, regions.get(), rule_with(1, 20, 0.4, 2, false), scratch);
  EXPECT_EQ(d2.at(5, 5), 12);
  EXPECT_EQ(d2.at(1, 1), 11);
  EXPECT_EQ(d2.at(3, 3), 10);

  auto d0 = disp;
  histogram_vote(d0.view(), 32, regions.get(), rule_with(1, 20, 0.4, 0, false), scratch);
  EXPECT_EQ(d0.at(1, 1), 10);
}

TEST(HistogramVote, MinCountCountsReliablePixelsOnly) {
  const Regions regions(test::full_arms(7, 7));
  VoteScratch scratch;
  auto disp = filled(7, 7, 10);
  disp.at(3, 3) = 20;
  for (int x : {50, 49}) {
    auto d = disp;
    histogram_vote(d.view(), 32, regions.get(), rule_with(1, x, 0.0, 0, false), scratch);
    EXPECT_EQ(d.at(3, 3), x <= 49 ? 10 : 20) << "min_count " << x;
  }
  for (int x = 0; x < 5; ++x) disp.at(x, 6) = kInv;  // 44 reliable pixels remain
  for (int x : {45, 44}) {
    auto d = disp;
    histogram_vote(d.view(), 32, regions.get(), rule_with(1, x, 0.0, 0, false), scratch);
    EXPECT_EQ(d.at(3, 3), x <= 44 ? 10 : 20) << "min_count " << x;
    EXPECT_EQ(d.at(0, 6), kInv);  // without fill_invalid unreliable pixels stay so
  }
}

TEST(HistogramVote, MinRatioOfTheWinner) {
  const Regions regions(test::full_arms(7, 7));
  VoteScratch scratch;
  Image<std::int16_t> disp(7, 7);
  // 20 pixels at 10, 15 at 30, 14 at 40: 10 wins with 20 / 49 = 0.408 of the votes.
  for (int i = 0; i < 49; ++i)
    disp.at(i % 7, i / 7) = static_cast<std::int16_t>(i < 20 ? 10 : i < 35 ? 30 : 40);
  auto strict = disp;
  histogram_vote(strict.view(), 64, regions.get(), rule_with(1, 20, 0.45, 1, false), scratch);
  EXPECT_EQ(values(strict), values(disp));
  auto loose = disp;
  histogram_vote(loose.view(), 64, regions.get(), rule_with(1, 20, 0.40, 1, false), scratch);
  for (int v : values(loose)) ASSERT_EQ(v, 10);
}

TEST(HistogramVote, WinnerMayNeedExactlyMinRatio) {
  const Regions regions(test::full_arms(5, 4));  // 20 pixels per region
  VoteScratch scratch;
  Image<std::int16_t> disp(5, 4);
  for (int i = 0; i < 20; ++i)
    disp.at(i % 5, i / 5) = static_cast<std::int16_t>(i < 8 ? 10 : i < 14 ? 20 : 30);
  histogram_vote(disp.view(), 64, regions.get(), VoteRule{}, scratch);
  EXPECT_EQ(disp.at(4, 3), 10);
}

TEST(HistogramVote, TieGoesToTheSmallerDisparity) {
  const Regions regions(test::full_arms(6, 6));
  VoteScratch scratch;
  Image<std::int16_t> disp(6, 6);
  for (int i = 0; i < 36; ++i) disp.at(i % 6, i / 6) = static_cast<std::int16_t>(i % 2 ? 20 : 10);
  histogram_vote(disp.view(), 32, regions.get(), rule_with(1, 1, 0.5, 1, false), scratch);
  for (int v : values(disp)) ASSERT_EQ(v, 10);
}

TEST(HistogramVote, EachPixelVotesInItsOwnRegion) {
  // Columns 0..4 and 5..9 are separate regions, each with an outlier carrying the other's value.
  const Regions regions(block_arms(10, 5, {{0, 5}, {5, 10}}));
  VoteScratch scratch;
  Image<std::int16_t> disp(10, 5);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 10; ++x) disp.at(x, y) = static_cast<std::int16_t>(x < 5 ? 10 : 30);
  disp.at(2, 2) = 30;
  disp.at(7, 2) = 10;
  Image<std::uint8_t> changed(10, 5);
  histogram_vote(disp.view(), 40, regions.get(), VoteRule{}, scratch, changed.view());
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 10; ++x) {
      ASSERT_EQ(disp.at(x, y), x < 5 ? 10 : 30) << x << "," << y;
      ASSERT_EQ(changed.at(x, y), (y == 2 && (x == 2 || x == 7)) ? 1 : 0) << x << "," << y;
    }
}

TEST(HistogramVote, FillInvalidGivesUnreliablePixelsTheDecidedValue) {
  const Regions regions(test::full_arms(7, 7));
  VoteScratch scratch;
  auto disp = filled(7, 7, 10);
  disp.at(0, 0) = kInv;
  disp.at(6, 3) = kInv;
  Image<std::uint8_t> changed(7, 7);

  auto keep = disp;
  histogram_vote(keep.view(), 32, regions.get(), rule_with(2, 20, 0.4, 1, false), scratch,
                 changed.view());
  EXPECT_EQ(keep.at(0, 0), kInv);
  EXPECT_EQ(keep.at(6, 3), kInv);
  EXPECT_EQ(changed.at(0, 0), 0);

  auto fill = disp;
  histogram_vote(fill.view(), 32, regions.get(), rule_with(1, 20, 0.4, 1, true), scratch,
                 changed.view());
  for (int v : values(fill)) ASSERT_EQ(v, 10);
  EXPECT_EQ(changed.at(0, 0), 1);
  EXPECT_EQ(changed.at(6, 3), 1);
  EXPECT_EQ(changed.at(3, 3), 0);

  // An undecided region fills nothing.
  auto sparse = disp;
  histogram_vote(sparse.view(), 32, regions.get(), rule_with(1, 48, 0.4, 1, true), scratch);
  EXPECT_EQ(sparse.at(0, 0), kInv);
}

TEST(HistogramVote, IterationsPropagateFilledValues) {
  const Regions regions(row_triplet_arms(6, 1));
  VoteScratch scratch;
  const auto start = [] {
    Image<std::int16_t> d(6, 1);
    const int v[6] = {5, 5, kInv, kInv, kInv, kInv};
    for (int x = 0; x < 6; ++x) d.at(x, 0) = static_cast<std::int16_t>(v[x]);
    return d;
  }();
  const std::vector<int> expected[] = {
      {5, 5, kInv, kInv, kInv, kInv},
      {5, 5, 5, kInv, kInv, kInv},
      {5, 5, 5, 5, kInv, kInv},
      {5, 5, 5, 5, 5, kInv},
  };
  for (int it = 0; it < 4; ++it) {
    auto d = start;
    histogram_vote(d.view(), 8, regions.get(), rule_with(it, 1, 0.5, 0, true), scratch);
    EXPECT_EQ(values(d), expected[it]) << it << " iterations";
  }
}

TEST(HistogramVote, AllInvalidStaysInvalidAndClearsChanged) {
  const Regions regions(test::full_arms(4, 3));
  VoteScratch scratch;
  auto disp = filled(4, 3, kInv);
  Image<std::uint8_t> changed(4, 3);
  changed.fill(1);
  histogram_vote(disp.view(), 8, regions.get(), rule_with(3, 1, 0.0, 0, true), scratch,
                 changed.view());
  for (int v : values(disp)) EXPECT_EQ(v, kInv);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x) EXPECT_EQ(changed.at(x, y), 0);
}

TEST(HistogramVote, AgreesWithABruteForceVoteOnRandomMaps) {
  std::mt19937 rng(21);
  const int w = 30, h = 20, max_d = 6;
  const Regions regions(test::random_arms(rng, w, h, 6));
  const CrossArms& a = regions.get().arms();
  std::uniform_int_distribution<int> value(0, 15);
  Image<std::int16_t> disp(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      // Mostly 3, with noise and unreliable pixels, so that many regions decide and some not.
      const int v = value(rng);
      disp.at(x, y) = static_cast<std::int16_t>(v < 8 ? 3 : v == 8 ? kInv : v - 9);
    }
  const VoteRule rule = rule_with(1, 8, 0.5, 1, true);
  // Reference: explicit histogram over the horizontal-first region of each pixel.
  Image<std::int16_t> expected = disp;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      std::vector<int> hist(max_d + 1, 0);
      int total = 0;
      for (int j = y - a.up.at(x, y); j <= y + a.down.at(x, y); ++j)
        for (int i = x - a.left.at(x, j); i <= x + a.right.at(x, j); ++i)
          if (disp.at(i, j) != kInv) {
            ++hist[disp.at(i, j)];
            ++total;
          }
      const int winner =
          static_cast<int>(std::max_element(hist.begin(), hist.end()) - hist.begin());
      const bool decided = total >= rule.min_count && 2 * hist[winner] >= total;
      const int own = disp.at(x, y);
      if (decided && (own == kInv || std::abs(own - winner) > rule.tolerance))
        expected.at(x, y) = static_cast<std::int16_t>(winner);
    }
  long moved = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) moved += expected.at(x, y) != disp.at(x, y);
  ASSERT_GT(moved, 10);         // the vote has work to do...
  ASSERT_LT(moved, w * h / 2);  // ...and not everywhere
  VoteScratch scratch;
  histogram_vote(disp.view(), max_d, regions.get(), rule, scratch);
  EXPECT_EQ(values(disp), values(expected));
}

}  // namespace
}  // namespace dco::stereo
