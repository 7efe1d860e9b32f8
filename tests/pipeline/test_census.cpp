#include "dco/pipeline/stereo/census.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "pipeline_test_support.hpp"

namespace dco::stereo {
namespace {

// The descriptor reads the window row-major as a binary number, centre skipped: the first
// neighbour (top-left) is the most significant of the window_w * window_h - 1 used bits.
std::uint64_t naive_census(const Image<std::uint8_t>& g, int ww, int wh, int x, int y) {
  const int n = ww * wh - 1;
  const std::uint8_t centre = g.at(x, y);
  std::uint64_t bits = 0;
  int k = 0;
  for (int dy = -wh / 2; dy <= wh / 2; ++dy)
    for (int dx = -ww / 2; dx <= ww / 2; ++dx) {
      if (dx == 0 && dy == 0) continue;
      const int nx = std::clamp(x + dx, 0, g.width() - 1);
      const int ny = std::clamp(y + dy, 0, g.height() - 1);
      if (g.at(nx, ny) < centre) bits |= std::uint64_t{1} << (n - 1 - k);
      ++k;
    }
  return bits;
}

Image<std::uint8_t> from_rows(const std::vector<std::vector<int>>& rows) {
  Image<std::uint8_t> img(static_cast<int>(rows[0].size()), static_cast<int>(rows.size()));
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) img.at(x, y) = static_cast<std::uint8_t>(rows[y][x]);
  return img;
}

Image<std::uint64_t> census(const Image<std::uint8_t>& g, int ww, int wh) {
  Image<std::uint64_t> out(g.width(), g.height());
  out.fill(0xdeadbeefdeadbeefull);  // every pixel must be written
  census_transform(g.view(), ww, wh, out.view());
  return out;
}

TEST(Census, HandComputed3x3) {
  const auto g = from_rows({{10, 20, 30}, {40, 50, 60}, {70, 80, 90}});
  const auto c = census(g, 3, 3);
  // Centre 50: neighbours 10 20 30 40 | 60 70 80 90 -> darker, darker, darker, darker, no x4.
  EXPECT_EQ(c.at(1, 1), 0b11110000u);
  // Corner 10: every neighbour, clamped ones included, is at least as bright.
  EXPECT_EQ(c.at(0, 0), 0u);
  // Corner 90, clamped window:  50 60 60 / 80 [90] 90 / 80 90 90.
  EXPECT_EQ(c.at(2, 2), 0b11110100u);
  // Top edge 20, clamped window: 10 20 30 / 10 [20] 30 / 40 50 60.
  EXPECT_EQ(c.at(1, 0), 0b10010000u);
}

TEST(Census, EqualNeighbourIsNotDarker) {
  const auto g = from_rows({{7, 7, 7}, {7, 7, 7}, {7, 7, 6}});
  const auto c = census(g, 3, 3);
  EXPECT_EQ(c.at(1, 1), 0b00000001u);  // only the last neighbour (bottom-right) is darker
  EXPECT_EQ(c.at(2, 2), 0u);
  EXPECT_EQ(c.at(0, 0), 0u);
}

TEST(Census, Default9x7WindowOnTinyImageClampsBorders) {
  // 5x4 image, bright except one dark pixel at (0, 0).
  Image<std::uint8_t> g(5, 4);
  g.fill(100);
  g.at(0, 0) = 0;
  const auto c = census(g, 9, 7);
  constexpr int kBits = 9 * 7 - 1;  // 62
  EXPECT_EQ(c.at(0, 0), 0u);
  // At (4, 3) only the window's top-left neighbour (dx = -4, dy = -3) clamps onto (0, 0).
  EXPECT_EQ(c.at(4, 3), std::uint64_t{1} << (kBits - 1));
  // At (2, 1) the neighbours with x + dx <= 0 and y + dy <= 0 do: dx in -4..-2, dy in -3..-1.
  std::uint64_t expected = 0;
  for (int dy = -3; dy <= -1; ++dy)
    for (int dx = -4; dx <= -2; ++dx) {
      const int k = (dy + 3) * 9 + (dx + 4);  // rows above the centre row: no skip yet
      expected |= std::uint64_t{1} << (kBits - 1 - k);
    }
  EXPECT_EQ(c.at(2, 1), expected);
  EXPECT_EQ(std::popcount(c.at(2, 1)), 9);
  // A bright pixel far from the dark one in the window still sees it: x + dx <= 0 needs dx = -3
  // or -4 at x = 3, y + dy <= 0 needs dy <= -2 at y = 2.
  EXPECT_EQ(std::popcount(c.at(3, 2)), 4);
  // No bit above the 62 used ones is ever set.
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 5; ++x) EXPECT_EQ(c.at(x, y) >> kBits, 0u) << x << "," << y;
}

TEST(Census, ConstantImageGivesZero) {
  Image<std::uint8_t> g(23, 11);
  for (int v : {0, 77, 255}) {
    g.fill(static_cast<std::uint8_t>(v));
    for (auto [ww, wh] : {std::pair{3, 3}, {9, 7}, {13, 5}}) {
      const auto c = census(g, ww, wh);
      for (int y = 0; y < g.height(); ++y)
        for (int x = 0; x < g.width(); ++x) ASSERT_EQ(c.at(x, y), 0u) << x << "," << y;
    }
  }
}

TEST(Census, FullSixtyFourBitWindowUsesTheTopBit) {
  // 13 x 5 = 65 pixels: 64 comparisons fill the whole word.
  Image<std::uint8_t> g(13, 5);
  g.fill(0);
  g.at(6, 2) = 255;
  const auto c = census(g, 13, 5);
  EXPECT_EQ(c.at(6, 2), ~std::uint64_t{0});
  g.fill(255);
  g.at(6, 2) = 0;
  g.at(0, 0) = 0;  // the first neighbour equals the centre: not darker
  EXPECT_EQ(census(g, 13, 5).at(6, 2), 0u);
  g.at(6, 2) = 1;  // now it is, and it is the most significant bit
  EXPECT_EQ(census(g, 13, 5).at(6, 2), std::uint64_t{1} << 63);
}

TEST(Census, MatchesNaiveReferenceOnRandomImages) {
  std::mt19937 rng(1234);
  const std::pair<int, int> windows[] = {{3, 3}, {5, 5},  {9, 7},  {7, 9},  {1, 3},
                                         {3, 1}, {13, 5}, {5, 13}, {1, 65}, {3, 21}};
  const std::pair<int, int> sizes[] = {{1, 1}, {2, 3}, {3, 2}, {4, 9}, {9, 4}, {17, 13}, {40, 6}};
  for (auto [ww, wh] : windows)
    for (auto [w, h] : sizes) {
      // A small value range makes equal neighbours frequent.
      const auto g = test::random_image<std::uint8_t>(rng, w, h, 1, 0, 5);
      const auto c = census(g, ww, wh);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          ASSERT_EQ(c.at(x, y), naive_census(g, ww, wh, x, y))
              << "window " << ww << "x" << wh << " image " << w << "x" << h << " at " << x << ","
              << y;
    }
}

TEST(Census, WorksOnStridedSubViews) {
  std::mt19937 rng(99);
  const auto big = test::random_image<std::uint8_t>(rng, 50, 30, 1, 0, 255);
  const auto sub_in = big.view().sub(7, 5, 21, 14);
  Image<std::uint8_t> copy(21, 14);
  copy.copy_from(sub_in);

  Image<std::uint64_t> big_out(40, 20);
  big_out.fill(0);
  census_transform(sub_in, 9, 7, big_out.view().sub(3, 2, 21, 14));
  for (int y = 0; y < 14; ++y)
    for (int x = 0; x < 21; ++x)
      ASSERT_EQ(big_out.at(x + 3, y + 2), naive_census(copy, 9, 7, x, y)) << x << "," << y;
  // Nothing outside the output view was touched.
  EXPECT_EQ(big_out.at(2, 2), 0u);
  EXPECT_EQ(big_out.at(24, 2), 0u);
  EXPECT_EQ(big_out.at(3, 1), 0u);
  EXPECT_EQ(big_out.at(3, 16), 0u);
}

TEST(Census, HammingDistanceOfShiftedTextureIsZeroInTheInterior) {
  // The property matching relies on: a texture and its copy shifted by s give identical
  // descriptors wherever neither window reaches a border.
  std::mt19937 rng(5);
  const int w = 60, h = 20, s = 7;
  const auto left = test::random_image<std::uint8_t>(rng, w, h, 1, 0, 255);
  Image<std::uint8_t> right(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) right.at(x, y) = left.at(std::min(x + s, w - 1), y);
  const auto cl = census(left, 9, 7);
  const auto cr = census(right, 9, 7);
  for (int y = 0; y < h; ++y)
    for (int x = s + 4; x + 4 < w; ++x) ASSERT_EQ(cl.at(x, y), cr.at(x - s, y)) << x << "," << y;
}

}  // namespace
}  // namespace dco::stereo
