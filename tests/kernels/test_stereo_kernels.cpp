#include "dco/kernels/stereo_kernels.hpp"
#include "dco/kernels/stereo_pixel.hpp"
#include "for_each_target.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <hwy/targets.h>

namespace dco::kernels {
namespace {

// Widths around the lane counts of every target (4 .. 16 32-bit lanes, SVE up to 64), odd ones,
// and one below a single vector.
const std::vector<int> kWidths = {1, 3, 7, 8, 15, 16, 17, 31, 33, 63, 64, 65, 97, 130, 257};
// Blocks shorter and longer than a vector, and not multiples of the lane count.
const std::vector<int> kBlocks = {1, 3, 4, 16, 17, 40};

template <typename T>
std::vector<T> random_vector(std::mt19937& rng, std::size_t n, T lo, T hi) {
  std::uniform_int_distribution<std::uint64_t> dist(lo, hi);
  std::vector<T> v(n);
  for (T& e : v) e = static_cast<T>(dist(rng));
  return v;
}

std::vector<std::uint64_t> random_census(std::mt19937& rng, std::size_t n) {
  std::vector<std::uint64_t> v(n);
  for (auto& e : v) e = (std::uint64_t{rng()} << 32) | rng();
  return v;
}

// Arm lengths that never leave [0, limit): left[x] <= x, right[x] <= limit - 1 - x.
void random_arms(std::mt19937& rng, int limit, int max_arm, std::vector<std::uint8_t>& before,
                 std::vector<std::uint8_t>& after) {
  before.resize(static_cast<std::size_t>(limit));
  after.resize(static_cast<std::size_t>(limit));
  for (int i = 0; i < limit; ++i) {
    before[i] = static_cast<std::uint8_t>(rng() % (std::min(i, max_arm) + 1));
    after[i] = static_cast<std::uint8_t>(rng() % (std::min(limit - 1 - i, max_arm) + 1));
  }
}

struct Tables {
  std::vector<std::uint32_t> ad, census;
  CostTableView view;
  Tables(int channels, int max_arm) {
    std::mt19937 rng(7);
    const int ad_size = 255 * channels + 1;
    ad = random_vector<std::uint32_t>(rng, static_cast<std::size_t>((max_arm + 1) * ad_size), 0,
                                      2100);
    census =
        random_vector<std::uint32_t>(rng, static_cast<std::size_t>((max_arm + 1) * 65), 0, 2000);
    view = {ad.data(), ad_size, census.data(), 65, 4096};
  }
};

TEST(StereoKernels, RunsEveryTargetOfThisCpu) {
  std::string names;
  for (const std::int64_t target : hwy::SupportedAndGeneratedTargets())
    names += std::string(" ") + hwy::TargetName(target);
  std::printf("SIMD targets under test:%s\n", names.c_str());
  EXPECT_NE(names.find(std::string(" ") + simd_target()), std::string::npos)
      << "dispatch picked " << simd_target();
#if HWY_ARCH_ARM_A64
  // NEON is the baseline of every 64-bit Arm CPU: its path must be among those compared.
  EXPECT_NE(names.find(" NEON"), std::string::npos) << names;
#elif HWY_ARCH_X86_64
  EXPECT_NE(names.find(" SSE4"), std::string::npos) << names;
#endif
}

TEST(StereoKernels, PackPixelsPutsChannelsInBytes) {
  const std::uint8_t bgr[6] = {1, 2, 3, 250, 251, 252};
  std::uint32_t out[2];
  pack_pixels(bgr, 3, 2, out);
  EXPECT_EQ(out[0], 0x030201u);
  EXPECT_EQ(out[1], 0xfcfbfau);
  pack_pixels(bgr, 1, 2, out);
  EXPECT_EQ(out[0], 1u);
  EXPECT_EQ(out[1], 2u);
  // A grey row long enough for the vectorised loop, with its tail.
  std::uint8_t grey[37];
  for (int x = 0; x < 37; ++x) grey[x] = static_cast<std::uint8_t>(255 - 7 * x);
  std::uint32_t wide[37];
  pack_pixels(grey, 1, 37, wide);
  for (int x = 0; x < 37; ++x) EXPECT_EQ(wide[x], grey[x]) << x;
}

TEST(StereoKernels, CensusMatchesScalarAndTheDefinition) {
  std::mt19937 rng(8);
  for (const int w : {1, 4, 9, 16, 31, 64, 100, 150, 257}) {
    const int h = 9;
    // Few grey levels, so equal neighbours (not darker: bit clear) occur often; on wide rows
    // the whole range, both sides of 128 included.
    const auto image =
        random_vector<std::uint8_t>(rng, static_cast<std::size_t>(w * h), 0, w > 100 ? 255 : 3);
    for (const auto& [ww, wh] : {std::pair{9, 7}, std::pair{3, 3}, std::pair{5, 5}, std::pair{1, 9},
                                 std::pair{7, 9}, std::pair{13, 3}}) {
      if (ww * wh - 1 > 64) continue;
      for (int y = 0; y < h; ++y) {
        std::vector<const std::uint8_t*> rows;
        for (int j = 0; j < wh; ++j)
          rows.push_back(image.data() + std::clamp(y + j - wh / 2, 0, h - 1) * w);
        std::vector<std::uint64_t> expected(static_cast<std::size_t>(w));
        scalar::census_row(rows.data(), w, ww, wh, expected.data());
        if (y == h / 2 && w > ww) {  // one pixel by the definition, bit by bit
          const int x = w / 2;
          int bit = ww * wh - 2;
          for (int j = 0; j < wh; ++j)
            for (int dx = -(ww / 2); dx <= ww / 2; ++dx) {
              if (j == wh / 2 && dx == 0) continue;
              const int xx = std::clamp(x + dx, 0, w - 1);
              const bool darker = rows[j][xx] < rows[wh / 2][x];
              ASSERT_EQ((expected[x] >> bit) & 1u, darker ? 1u : 0u) << ww << "x" << wh;
              --bit;
            }
        }
        for_each_target([&] {
          std::vector<std::uint64_t> out(expected.size(), 5);
          census_row(rows.data(), w, ww, wh, out.data());
          ASSERT_EQ(out, expected)
              << "width " << w << " window " << ww << "x" << wh << " row " << y;
        });
      }
    }
  }
}

TEST(StereoKernels, CrossArmsMatchScalar) {
  std::mt19937 rng(6);
  for (const int channels : {1, 3}) {
    for (const int w : {1, 5, 16, 40, 77, 130}) {
      const int h = 31;
      const std::ptrdiff_t stride = w + 3;
      // Patches of similar colour with small noise, so arms of every length occur.
      std::vector<std::uint32_t> image(static_cast<std::size_t>(h * stride));
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          std::uint8_t px[3];
          for (int c = 0; c < channels; ++c)
            px[c] =
                static_cast<std::uint8_t>(((x / 9) * 37 + (y / 7) * 59 + c * 17) % 256 + rng() % 5);
          pack_pixels(px, channels, 1, &image[y * stride + x]);
        }
      for (const ArmParams params :
           {ArmParams{34, 17, 20, 6}, ArmParams{5, 2, 12, 3}, ArmParams{255, 0, 255, 1}}) {
        for (int y = 0; y < h; ++y) {
          std::vector<std::uint8_t> expected(static_cast<std::size_t>(4 * w));
          std::uint8_t* e = expected.data();
          scalar::cross_arms_row(image.data(), stride, w, h, y, params, e, e + w, e + 2 * w,
                                 e + 3 * w);
          for_each_target([&] {
            std::vector<std::uint8_t> out(expected.size(), 99);
            std::uint8_t* o = out.data();
            cross_arms_row(image.data(), stride, w, h, y, params, o, o + w, o + 2 * w, o + 3 * w);
            ASSERT_EQ(out, expected) << "channels " << channels << " width " << w << " row " << y
                                     << " arm_max " << params.arm_max;
          });
        }
      }
    }
  }
}

TEST(StereoKernels, GreyCrossArmsEqualThoseOfPackedPixels) {
  std::mt19937 rng(7);
  // Widths below, at and past every target's byte lanes (16 .. 64), and past arm_max 255 at both
  // row ends.
  for (const int w : {1, 7, 16, 17, 40, 64, 65, 130, 200, 333, 700}) {
    const int h = 23;
    const std::ptrdiff_t stride = w + 5;
    std::vector<std::uint8_t> grey(static_cast<std::size_t>(h * stride));
    std::vector<std::uint32_t> packed(grey.size());
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const auto v = static_cast<std::uint8_t>(((x / 11) * 37 + (y / 5) * 59) % 256 + rng() % 4);
        grey[static_cast<std::size_t>(y * stride + x)] = v;
        pack_pixels(&v, 1, 1, &packed[static_cast<std::size_t>(y * stride + x)]);
      }
    for (const ArmParams params : {ArmParams{34, 17, 20, 6}, ArmParams{17, 8, 20, 6},
                                   ArmParams{5, 2, 12, 3}, ArmParams{255, 0, 255, 1}}) {
      for (int y = 0; y < h; ++y) {
        std::vector<std::uint8_t> expected(static_cast<std::size_t>(4 * w));
        std::uint8_t* e = expected.data();
        scalar::cross_arms_row(packed.data(), stride, w, h, y, params, e, e + w, e + 2 * w,
                               e + 3 * w);
        std::vector<std::uint8_t> reference(expected.size(), 99);
        std::uint8_t* r = reference.data();
        scalar::grey_cross_arms_row(grey.data(), stride, w, h, y, params, r, r + w, r + 2 * w,
                                    r + 3 * w);
        ASSERT_EQ(reference, expected) << "width " << w << " row " << y;
        for_each_target([&] {
          std::vector<std::uint8_t> out(expected.size(), 99);
          std::uint8_t* o = out.data();
          grey_cross_arms_row(grey.data(), stride, w, h, y, params, o, o + w, o + 2 * w, o + 3 * w);
          ASSERT_EQ(out, expected)
              << "width " << w << " row " << y << " arm_max " << params.arm_max;
        });
      }
    }
  }
}

TEST(StereoKernels, MatchingCostMatchesScalar) {
  std::mt19937 rng(1);
  for (const int channels : {1, 3}) {
    const Tables tables(channels, 34);
    for (const int w : kWidths) {
      std::vector<std::uint8_t> left_px =
          random_vector<std::uint8_t>(rng, static_cast<std::size_t>(w * channels), 0, 255);
      std::vector<std::uint8_t> right_px =
          random_vector<std::uint8_t>(rng, static_cast<std::size_t>(w * channels), 0, 255);
      if (w > 2) {  // the extreme differences: 0 and 255 in every channel
        std::fill(left_px.begin(), left_px.begin() + channels, 0);
        std::fill(right_px.begin(), right_px.begin() + channels, 255);
      }
      std::vector<std::uint32_t> left(static_cast<std::size_t>(w)), right(left.size());
      pack_pixels(left_px.data(), channels, w, left.data());
      pack_pixels(right_px.data(), channels, w, right.data());
      const auto cl = random_census(rng, left.size());
      auto cr = random_census(rng, left.size());
      if (w > 2) cr[0] = ~cl[w - 1];  // Hamming distance 64
      const auto arm = random_vector<std::uint8_t>(rng, left.size(), 0, 34);
      const CostRow row{left.data(), right.data(), cl.data(), cr.data(), arm.data(), w};
      for (const int d : {0, 1, 5, w / 2, w - 1, w, w + 3}) {
        std::vector<std::uint32_t> expected(left.size(), 1), out(left.size(), 2);
        scalar::matching_cost_row(row, tables.view, d, expected.data());
        for_each_target([&] {
          std::fill(out.begin(), out.end(), 2);
          matching_cost_row(row, tables.view, d, out.data());
          ASSERT_EQ(out, expected) << "channels " << channels << " width " << w << " d " << d;
        });
      }
    }
  }
}

TEST(StereoKernels, BlockMatchingCostMatchesTheRowKernel) {
  std::mt19937 rng(15);
  for (const int channels : {1, 3}) {
    const Tables tables(channels, 34);
    for (const int w : {1, 7, 20, 45, 130}) {
      std::vector<std::uint32_t> left(static_cast<std::size_t>(w)), right(left.size());
      for (auto& px : left) px = rng() & (channels == 3 ? 0xffffffu : 0xffu);
      for (auto& px : right) px = rng() & (channels == 3 ? 0xffffffu : 0xffu);
      const auto cl = random_census(rng, left.size());
      auto cr = random_census(rng, left.size());
      // Hamming distance 64, the one census entry past four 16-lane vectors: every other pixel
      // at disparity 3.
      for (int x = 3; x < w; x += 2) cr[x - 3] = ~cl[x];
      const auto arm = random_vector<std::uint8_t>(rng, left.size(), 0, 34);
      const CostRow row{left.data(), right.data(), cl.data(), cr.data(), arm.data(), w};
      for (const int d0 : {0, 3, 16, w - 1}) {
        for (const int count : kBlocks) {
          // The block layout is the row kernel's slices, interleaved.
          std::vector<std::uint32_t> expected(static_cast<std::size_t>(w * count));
          std::vector<std::uint32_t> slice(left.size());
          for (int k = 0; k < count; ++k) {
            scalar::matching_cost_row(row, tables.view, d0 + k, slice.data());
            for (int x = 0; x < w; ++x) expected[x * count + k] = slice[x];
          }
          std::vector<std::uint32_t> reference(expected.size());
          scalar::block_matching_cost_row(row, tables.view, d0, count, reference.data());
          ASSERT_EQ(reference, expected);
          // Running sums along the row, one block ahead (the aggregation's prefix).
          std::vector<std::uint32_t> sums(static_cast<std::size_t>((w + 1) * count), 0);
          for (int x = 0; x < w; ++x)
            for (int k = 0; k < count; ++k)
              sums[(x + 1) * count + k] = sums[x * count + k] + expected[x * count + k];
          std::vector<std::uint32_t> reference_sums(sums.size(), 7);
          scalar::block_matching_cost_sums_row(row, tables.view, d0, count, reference_sums.data());
          ASSERT_EQ(reference_sums, sums);
          // Pixels [begin, end) only: sums starting over at begin, nothing written elsewhere.
          const int begin = w / 3, end = w - w / 4;
          std::vector<std::uint32_t> range_sums(sums.size(), 7);
          for (int k = 0; k < count; ++k) range_sums[begin * count + k] = 0;
          for (int x = begin; x < end; ++x)
            for (int k = 0; k < count; ++k)
              range_sums[(x + 1) * count + k] = range_sums[x * count + k] + expected[x * count + k];
          std::vector<std::uint32_t> reference_range(sums.size(), 7);
          scalar::block_matching_cost_sums_range(row, tables.view, d0, count, begin, end,
                                                 reference_range.data());
          ASSERT_EQ(reference_range, range_sums);
          for_each_target([&] {
            std::vector<std::uint32_t> out(expected.size(), 1);
            block_matching_cost_row(row, tables.view, d0, count, out.data());
            ASSERT_EQ(out, expected)
                << "channels " << channels << " width " << w << " d0 " << d0 << " count " << count;
            std::vector<std::uint32_t> out_sums(sums.size(), 7);
            block_matching_cost_sums_row(row, tables.view, d0, count, out_sums.data());
            ASSERT_EQ(out_sums, sums)
                << "channels " << channels << " width " << w << " d0 " << d0 << " count " << count;
            std::vector<std::uint32_t> out_range(sums.size(), 7);
            block_matching_cost_sums_range(row, tables.view, d0, count, begin, end,
                                           out_range.data());
            ASSERT_EQ(out_range, range_sums) << "range, channels " << channels << " width " << w
                                             << " d0 " << d0 << " count " << count;
          });
        }
      }
    }
  }
}

// Grey tables whose AD rows turn constant early (as the exponential of Eq. 1 does near 80 grey
// levels) go through the kernel's register lookup: every head length it takes, and one it does
// not, against the scalar reference, which reads the table itself.
TEST(StereoKernels, BlockMatchingCostLooksUpShortAdRowsInRegisters) {
  std::mt19937 rng(9);
  for (const int flat_from : {1, 17, 63, 80, 95, 96}) {
    Tables tables(1, 17);
    for (int arm = 0; arm <= 17; ++arm) {
      std::uint32_t* row = tables.ad.data() + arm * tables.view.ad_size;
      // Rows turn constant at flat_from (arm 5: the entry before it differs) or earlier.
      if (arm == 5) {
        std::fill(row + flat_from, row + tables.view.ad_size, row[flat_from - 1] + 1);
      } else {
        const int from = static_cast<int>(rng() % flat_from) + 1;
        std::fill(row + from, row + tables.view.ad_size, row[from - 1]);
      }
    }
    tables.view.ad_flat_from = flat_from;
    const int w = 150;
    std::vector<std::uint32_t> left(static_cast<std::size_t>(w)), right(left.size());
    for (auto& px : left) px = rng() & 0xffu;
    for (auto& px : right) px = rng() & 0xffu;
    right[40] = left[57] ^ 0xffu;  // differences of 255 occur
    const auto cl = random_census(rng, left.size());
    const auto cr = random_census(rng, left.size());
    const auto arm = random_vector<std::uint8_t>(rng, left.size(), 0, 17);
    const CostRow row{left.data(), right.data(), cl.data(), cr.data(), arm.data(), w};
    for (const int d0 : {0, 16, 32}) {
      std::vector<std::uint32_t> expected(static_cast<std::size_t>(w * 16));
      scalar::block_matching_cost_row(row, tables.view, d0, 16, expected.data());
      std::vector<std::uint32_t> expected_sums(static_cast<std::size_t>((w + 1) * 16));
      scalar::block_matching_cost_sums_row(row, tables.view, d0, 16, expected_sums.data());
      for_each_target([&] {
        std::vector<std::uint32_t> out(expected.size(), 1);
        block_matching_cost_row(row, tables.view, d0, 16, out.data());
        ASSERT_EQ(out, expected) << "flat from " << flat_from << " d0 " << d0;
        std::vector<std::uint32_t> sums(expected_sums.size(), 1);
        block_matching_cost_sums_row(row, tables.view, d0, 16, sums.data());
        ASSERT_EQ(sums, expected_sums) << "flat from " << flat_from << " d0 " << d0;
      });
    }
  }
}

TEST(StereoKernels, MatchingCostOfIdenticalPixelsIsTheZeroEntry) {
  const Tables tables(3, 4);
  const int w = 40;
  std::vector<std::uint32_t> px(w, 0x123456u);
  std::vector<std::uint64_t> census(w, 0xf0f0u);
  std::vector<std::uint8_t> arm(w, 3);
  const CostRow row{px.data(), px.data(), census.data(), census.data(), arm.data(), w};
  for_each_target([&] {
    std::vector<std::uint32_t> out(w);
    matching_cost_row(row, tables.view, 2, out.data());
    EXPECT_EQ(out[0], 4096u);
    EXPECT_EQ(out[1], 4096u);
    for (int x = 2; x < w; ++x)
      ASSERT_EQ(out[x], tables.ad[3 * tables.view.ad_size] + tables.census[3 * 65]) << x;
  });
}

TEST(StereoKernels, HorizontalSumsMatchScalarAndBruteForce) {
  std::mt19937 rng(2);
  for (const int w : kWidths) {
    const auto in = random_vector<std::uint32_t>(rng, static_cast<std::size_t>(w), 0, 0xffffffffu);
    std::vector<std::uint8_t> left, right;
    random_arms(rng, w, 40, left, right);
    std::vector<std::uint32_t> prefix(static_cast<std::size_t>(w) + 1), expected(in.size());
    scalar::horizontal_sums_row(in.data(), left.data(), right.data(), w, prefix.data(),
                                expected.data());
    for (int x = 0; x < w; ++x) {
      std::uint32_t sum = 0;  // wraps like the kernel
      for (int i = x - left[x]; i <= x + right[x]; ++i) sum += in[i];
      ASSERT_EQ(expected[x], sum);
    }
    for_each_target([&] {
      std::vector<std::uint32_t> out(in.size());
      horizontal_sums_row(in.data(), left.data(), right.data(), w, prefix.data(), out.data());
      ASSERT_EQ(out, expected) << "width " << w;
    });
  }
}

TEST(StereoKernels, VerticalSumsMatchScalar) {
  std::mt19937 rng(3);
  for (const int w : kWidths) {
    const int h = 23;
    const std::ptrdiff_t stride = w + 5;  // rows padded, as in dco::Image
    auto columns =
        random_vector<std::uint32_t>(rng, static_cast<std::size_t>(h * stride), 0, 0xffffffffu);
    std::vector<std::uint32_t> accumulated = columns, reference = columns;
    for (int y = 1; y < h; ++y) {
      scalar::accumulate_row(reference.data() + (y - 1) * stride, reference.data() + y * stride, w);
      accumulate_row(accumulated.data() + (y - 1) * stride, accumulated.data() + y * stride, w);
    }
    ASSERT_EQ(accumulated, reference);
    std::vector<std::vector<std::uint8_t>> up(h), down(h);
    std::vector<std::uint8_t> column_up, column_down;
    for (auto& r : up) r.resize(static_cast<std::size_t>(w));
    for (auto& r : down) r.resize(static_cast<std::size_t>(w));
    for (int x = 0; x < w; ++x) {
      random_arms(rng, h, 9, column_up, column_down);
      for (int y = 0; y < h; ++y) {
        up[y][x] = column_up[y];
        down[y][x] = column_down[y];
      }
    }
    for (int y = 0; y < h; ++y) {
      std::vector<std::uint32_t> expected(static_cast<std::size_t>(w));
      scalar::vertical_sums_row(reference.data(), stride, y, up[y].data(), down[y].data(), w,
                                expected.data());
      for (int x = 0; x < w; ++x) {
        std::uint32_t sum = 0;
        for (int i = y - up[y][x]; i <= y + down[y][x]; ++i) sum += columns[i * stride + x];
        ASSERT_EQ(expected[x], sum);
      }
      for_each_target([&] {
        std::vector<std::uint32_t> out(static_cast<std::size_t>(w));
        vertical_sums_row(accumulated.data(), stride, y, up[y].data(), down[y].data(), w,
                          out.data());
        ASSERT_EQ(out, expected) << "width " << w << " row " << y;
      });
    }
  }
}

TEST(StereoKernels, RegionMeanMatchesScalar) {
  std::mt19937 rng(4);
  for (const int w : kWidths) {
    auto sums = random_vector<std::uint32_t>(rng, static_cast<std::size_t>(w), 0, 0xffffffffu);
    std::vector<std::uint32_t> reciprocal(sums.size());
    for (int x = 0; x < w; ++x) {
      const std::uint64_t n = 1 + rng() % 5000;
      reciprocal[x] = static_cast<std::uint32_t>(((std::uint64_t{1} << 31) + n / 2) / n);
    }
    if (w > 1) {  // the largest operands
      sums[0] = 0xffffffffu;
      reciprocal[0] = 1u << 31;
      sums[1] = 0;
    }
    std::vector<std::uint32_t> expected = sums;
    scalar::region_mean_row(expected.data(), reciprocal.data(), w);
    if (w > 1) {
      EXPECT_EQ(expected[0], 0xffffffffu);
    }
    for_each_target([&] {
      std::vector<std::uint32_t> out = sums;
      region_mean_row(out.data(), reciprocal.data(), w);
      ASSERT_EQ(out, expected) << "width " << w;
    });
  }
}

TEST(StereoKernels, RegionReciprocalMatchesScalarAndIsExact) {
  std::mt19937 rng(5);
  for (const int w : kWidths) {
    auto sizes = random_vector<std::uint32_t>(rng, static_cast<std::size_t>(w), 1, 511 * 511);
    // The smallest and largest regions, and divisors whose quotient is whole or just below it.
    const std::uint32_t edge[] = {1, 2, 3, 511 * 511, 1u << 16, 65537, 4761, (1u << 21) - 1};
    for (int x = 0; x < w && x < 8; ++x) sizes[static_cast<std::size_t>(x)] = edge[x];
    std::vector<std::uint32_t> expected(sizes.size());
    scalar::region_reciprocal_row(sizes.data(), w, expected.data());
    for (int x = 0; x < w; ++x) {
      const std::uint64_t n = sizes[static_cast<std::size_t>(x)];
      ASSERT_EQ(expected[static_cast<std::size_t>(x)], ((std::uint64_t{1} << 31) + n / 2) / n);
    }
    for_each_target([&] {
      std::vector<std::uint32_t> out(sizes.size(), 7u);
      region_reciprocal_row(sizes.data(), w, out.data());
      ASSERT_EQ(out, expected) << "width " << w;
    });
  }
  // Every size the kernel takes, against the 64-bit integer division.
  std::vector<std::uint32_t> all((1u << 21) - 1);
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<std::uint32_t>(i + 1);
  std::vector<std::uint32_t> out(all.size());
  for_each_target([&] {
    region_reciprocal_row(all.data(), static_cast<int>(all.size()), out.data());
    for (std::size_t i = 0; i < all.size(); ++i)
      ASSERT_EQ(out[i], ((std::uint64_t{1} << 31) + all[i] / 2) / all[i]) << "size " << all[i];
  });
}

TEST(StereoKernels, BlockHorizontalSumsMatchScalarAndBruteForce) {
  std::mt19937 rng(12);
  for (const int w : {1, 7, 16, 33}) {
    for (const int block : kBlocks) {
      const auto in =
          random_vector<std::uint32_t>(rng, static_cast<std::size_t>(w * block), 0, 0xffffffffu);
      std::vector<std::uint8_t> left, right;
      random_arms(rng, w, 40, left, right);
      std::vector<std::uint32_t> prefix(static_cast<std::size_t>((w + 1) * block));
      std::vector<std::uint32_t> expected(in.size());
      scalar::block_horizontal_sums_row(in.data(), left.data(), right.data(), w, block,
                                        prefix.data(), nullptr, expected.data());
      for (int x = 0; x < w; ++x)
        for (int k = 0; k < block; ++k) {
          std::uint32_t sum = 0;
          for (int i = x - left[x]; i <= x + right[x]; ++i) sum += in[i * block + k];
          ASSERT_EQ(expected[x * block + k], sum);
        }
      // With the row above's running sums added in the same pass (wrapping like the sums).
      const auto above =
          random_vector<std::uint32_t>(rng, static_cast<std::size_t>(w * block), 0, 0xffffffffu);
      std::vector<std::uint32_t> expected_added(in.size());
      scalar::block_horizontal_sums_row(in.data(), left.data(), right.data(), w, block,
                                        prefix.data(), above.data(), expected_added.data());
      for (std::size_t i = 0; i < in.size(); ++i)
        ASSERT_EQ(expected_added[i], static_cast<std::uint32_t>(expected[i] + above[i]));
      for_each_target([&] {
        std::vector<std::uint32_t> from_prefix(in.size());
        block_window_sums_row(prefix.data(), left.data(), right.data(), w, block, above.data(),
                              from_prefix.data());
        ASSERT_EQ(from_prefix, expected_added) << "width " << w << " block " << block;
        std::vector<std::uint32_t> out(in.size());
        block_horizontal_sums_row(in.data(), left.data(), right.data(), w, block, prefix.data(),
                                  nullptr, out.data());
        ASSERT_EQ(out, expected) << "width " << w << " block " << block;
        block_horizontal_sums_row(in.data(), left.data(), right.data(), w, block, prefix.data(),
                                  above.data(), out.data());
        ASSERT_EQ(out, expected_added) << "width " << w << " block " << block;
      });
    }
  }
}

TEST(StereoKernels, BlockVerticalSumsAndMeansMatchScalar) {
  std::mt19937 rng(13);
  for (const int w : {1, 7, 16, 33}) {
    for (const int block : kBlocks) {
      const int h = 19;
      const std::ptrdiff_t stride = w * block + 2;
      auto columns =
          random_vector<std::uint32_t>(rng, static_cast<std::size_t>(h * stride), 0, 0xffffffffu);
      std::vector<std::uint32_t> sums = columns;
      for (int y = 1; y < h; ++y)
        scalar::accumulate_row(sums.data() + ((y + 4) % h) * stride,
                               sums.data() + ((y + 5) % h) * stride, w * block);
      // Rows through a pointer table, out of memory order (as in a ring buffer).
      std::vector<const std::uint32_t*> rows(static_cast<std::size_t>(h));
      for (int i = 0; i < h; ++i) rows[i] = sums.data() + ((i + 5) % h) * stride;
      std::vector<std::uint8_t> up(static_cast<std::size_t>(w)), down(up.size());
      std::vector<std::uint8_t> column_up, column_down;
      const int y = static_cast<int>(rng() % h);
      for (int x = 0; x < w; ++x) {
        random_arms(rng, h, 12, column_up, column_down);
        up[x] = column_up[y];
        down[x] = column_down[y];
      }
      std::vector<std::uint32_t> reciprocal(up.size());
      for (auto& r : reciprocal) r = static_cast<std::uint32_t>(rng() % (1u << 31));
      std::vector<std::uint32_t> expected(static_cast<std::size_t>(w * block));
      scalar::block_vertical_sums_row(rows.data(), y, up.data(), down.data(), w, block, nullptr,
                                      expected.data());
      for (int x = 0; x < w; ++x)
        for (int k = 0; k < block; ++k) {
          std::uint32_t sum = 0;
          for (int i = y - up[x]; i <= y + down[x]; ++i)
            sum += columns[((i + 5) % h) * stride + x * block + k];
          ASSERT_EQ(expected[x * block + k], sum);
        }
      // The means: the row kernel's, pixel by pixel.
      std::vector<std::uint32_t> expected_mean = expected;
      for (int x = 0; x < w; ++x) {
        const std::vector<std::uint32_t> r(static_cast<std::size_t>(block), reciprocal[x]);
        scalar::region_mean_row(expected_mean.data() + x * block, r.data(), block);
      }
      std::vector<std::uint32_t> fused_mean(expected.size());
      scalar::block_vertical_sums_row(rows.data(), y, up.data(), down.data(), w, block,
                                      reciprocal.data(), fused_mean.data());
      ASSERT_EQ(fused_mean, expected_mean);
      for_each_target([&] {
        std::vector<std::uint32_t> out(expected.size());
        block_vertical_sums_row(rows.data(), y, up.data(), down.data(), w, block, nullptr,
                                out.data());
        ASSERT_EQ(out, expected) << "width " << w << " block " << block;
        std::vector<std::uint32_t> means(expected.size());
        block_vertical_sums_row(rows.data(), y, up.data(), down.data(), w, block, reciprocal.data(),
                                means.data());
        ASSERT_EQ(means, expected_mean) << "width " << w << " block " << block;
      });
    }
  }
}

TEST(StereoKernels, HalfMeansRowMatchesScalarAndTheRoundedBlockMean) {
  std::mt19937 rng(29);
  for (const int count : {1, 7, 16, 31, 32, 33, 63, 64, 65, 100, 640}) {
    const auto a = random_vector<std::uint8_t>(rng, static_cast<std::size_t>(2 * count), 0, 255);
    auto b = random_vector<std::uint8_t>(rng, static_cast<std::size_t>(2 * count), 0, 255);
    b[0] = 255;  // the largest sum, 4 * 255 + 2, still fits
    std::vector<std::uint8_t> expected(static_cast<std::size_t>(count));
    scalar::half_means_row(a.data(), b.data(), count, expected.data());
    for (int x = 0; x < count; ++x)
      ASSERT_EQ(expected[x], (a[2 * x] + a[2 * x + 1] + b[2 * x] + b[2 * x + 1] + 2) / 4) << x;
    for_each_target([&] {
      std::vector<std::uint8_t> out(expected.size() + 1, 7);
      half_means_row(a.data(), b.data(), count, out.data());
      EXPECT_EQ(out.back(), 7) << "nothing past the row";
      out.pop_back();
      ASSERT_EQ(out, expected) << "count " << count;
    });
  }
}

TEST(StereoKernels, BlocksToRowsTransposes) {
  std::mt19937 rng(17);
  for (const int w : {1, 4, 7, 16, 33, 48, 100}) {
    for (const int block : kBlocks) {
      for (const int count : {1, block / 2 + 1, block}) {
        // Region means below kNoCost, the largest included.
        auto blocks =
            random_vector<std::uint32_t>(rng, static_cast<std::size_t>(w * block), 0, kNoCost - 1);
        blocks[0] = kNoCost - 1;
        const std::ptrdiff_t stride = w + 3;
        std::vector<std::uint16_t> expected(static_cast<std::size_t>(stride * count), 7);
        scalar::blocks_to_rows(blocks.data(), w, block, count, expected.data(), stride);
        for (int k = 0; k < count; ++k)
          for (int x = 0; x < w; ++x) ASSERT_EQ(expected[k * stride + x], blocks[x * block + k]);
        for_each_target([&] {
          std::vector<std::uint16_t> rows(expected.size(), 7);
          blocks_to_rows(blocks.data(), w, block, count, rows.data(), stride);
          ASSERT_EQ(rows, expected) << "width " << w << " block " << block << " count " << count;
        });
      }
    }
  }
}

TEST(StereoKernels, BlockIndicatorMatchesScalar) {
  std::mt19937 rng(14);
  for (const int w : {1, 7, 16, 33}) {
    for (const int count : kBlocks) {
      const auto value = random_vector<std::int16_t>(rng, static_cast<std::size_t>(w), 0, 6);
      std::vector<std::int32_t> candidates(static_cast<std::size_t>(count));
      for (int k = 0; k < count; ++k) candidates[k] = k % 5 - 1;  // -1: never a value here
      std::vector<std::uint32_t> expected(static_cast<std::size_t>(w * count), 9);
      scalar::block_indicator_row(value.data(), w, candidates.data(), count, expected.data());
      for (int x = 0; x < w; ++x)
        for (int k = 0; k < count; ++k)
          ASSERT_EQ(expected[x * count + k], value[x] == candidates[k] ? 1u : 0u);
      for_each_target([&] {
        std::vector<std::uint32_t> out(expected.size(), 7);
        block_indicator_row(value.data(), w, candidates.data(), count, out.data());
        ASSERT_EQ(out, expected) << "width " << w << " count " << count;
      });
    }
  }
}

TEST(StereoKernels, BlockVoteMatchesScalar) {
  std::mt19937 rng(16);
  for (const int w : {1, 7, 16, 33}) {
    for (const int count : kBlocks) {
      // Few distinct counts, so equal maxima within a block and against the running best occur.
      const auto votes =
          random_vector<std::uint32_t>(rng, static_cast<std::size_t>(w * count), 0, 6);
      std::vector<std::int32_t> candidates(static_cast<std::size_t>(count));
      for (int k = 0; k < count; ++k) candidates[k] = 3 * k + 1;
      const auto total0 = random_vector<std::uint32_t>(rng, static_cast<std::size_t>(w), 0, 50);
      const auto best0 = random_vector<std::uint32_t>(rng, static_cast<std::size_t>(w), 0, 5);
      const std::vector<std::int16_t> value0(static_cast<std::size_t>(w), -1);
      auto total = total0;
      auto best = best0;
      auto value = value0;
      scalar::block_vote_row(votes.data(), w, candidates.data(), count, total.data(), best.data(),
                             value.data());
      for (int x = 0; x < w; ++x) {  // by definition: the first bin holding the largest count
        std::uint32_t sum = 0, most = best0[x];
        std::int16_t winner = -1;
        for (int k = 0; k < count; ++k) {
          sum += votes[x * count + k];
          if (votes[x * count + k] > most) {
            most = votes[x * count + k];
            winner = static_cast<std::int16_t>(candidates[k]);
          }
        }
        ASSERT_EQ(total[x], total0[x] + sum);
        ASSERT_EQ(best[x], most);
        ASSERT_EQ(value[x], winner);
      }
      for_each_target([&] {
        auto t = total0;
        auto b = best0;
        auto v = value0;
        block_vote_row(votes.data(), w, candidates.data(), count, t.data(), b.data(), v.data());
        ASSERT_EQ(t, total) << "width " << w << " count " << count;
        ASSERT_EQ(b, best) << "width " << w << " count " << count;
        ASSERT_EQ(v, value) << "width " << w << " count " << count;
      });
    }
  }
}

// Winner-takes-all state for one row, owned. With `left_over`, the left image's state holds
// random values instead (a previous frame's): disparity 0 must start it afresh without them.
struct WtaState {
  std::vector<std::uint16_t> best, second, below, above, prev1, prev2, runmin, best_right;
  std::vector<std::int16_t> disp, disp_right;
  explicit WtaState(int w, std::mt19937* left_over = nullptr)
      : best(w, kNoCost),
        second(w, kNoCost),
        below(w, kNoCost),
        above(w, kNoCost),
        prev1(w, kNoCost),
        prev2(w, kNoCost),
        runmin(w, kNoCost),
        best_right(w, kNoCost),
        disp(w, -1),
        disp_right(w, -1) {
    if (left_over == nullptr) return;
    for (auto* v : {&best, &second, &below, &above, &prev1, &prev2, &runmin})
      for (auto& e : *v) e = static_cast<std::uint16_t>((*left_over)() % 20);
    for (auto& e : disp) e = static_cast<std::int16_t>((*left_over)() % 40);
  }
  WtaRow row() {
    return {best.data(),  second.data(), below.data(), above.data(),      prev1.data(),
            prev2.data(), runmin.data(), disp.data(),  best_right.data(), disp_right.data()};
  }
  bool operator==(const WtaState&) const = default;
};

TEST(StereoKernels, WinnerTakesAllMatchesScalar) {
  std::mt19937 rng(5);
  for (const int w : kWidths) {
    for (const int disparities : {1, 2, 3, std::min(w, 40)}) {
      // Few distinct costs, so ties, the d - 1 / d + 1 neighbours and repeated minima all occur.
      const std::ptrdiff_t stride = w + 3;
      std::vector<std::uint16_t> volume(static_cast<std::size_t>(stride * disparities));
      for (int d = 0; d < disparities; ++d)
        for (int x = 0; x < w; ++x)
          volume[d * stride + x] = static_cast<std::uint16_t>(rng() % (d % 3 == 0 ? 9 : 0xffff));
      WtaState expected(w);
      for (int d = 0; d < disparities; ++d)
        scalar::wta_update_row(volume.data() + d * stride, stride, 1, w, d, expected.row());
      WtaState batched(w, &rng);  // the scalar reference fed several disparities per call
      for (int d = 0; d < disparities; d += 3)
        scalar::wta_update_row(volume.data() + d * stride, stride, std::min(3, disparities - d), w,
                               d, batched.row());
      ASSERT_TRUE(batched == expected);
      for (const int batch : {1, 4, 7, 16}) {
        for_each_target([&] {
          WtaState state(w, &rng);
          for (int d = 0; d < disparities; d += batch)
            wta_update_row(volume.data() + d * stride, stride, std::min(batch, disparities - d), w,
                           d, state.row());
          ASSERT_TRUE(state == expected)
              << "width " << w << " disparities " << disparities << " batch " << batch;
        });
      }
    }
  }
}

// Rows that skip some batches (a guided search) end in the same state, vector or scalar, and the
// skipped disparities never win, never count as the second cost and never become a neighbour.
TEST(StereoKernels, WinnerTakesAllSkippingBatchesMatchesScalar) {
  std::mt19937 rng(31);
  for (const int w : kWidths) {
    const int disparities = 40;
    const std::ptrdiff_t stride = w;
    std::vector<std::uint16_t> volume(static_cast<std::size_t>(stride * disparities));
    for (int d = 0; d < disparities; ++d)
      for (int x = 0; x < w; ++x)
        volume[d * stride + x] = static_cast<std::uint16_t>(rng() % (d % 3 == 0 ? 9 : 50));
    for (const int batch : {1, 2, 5, 16}) {
      // Batches 1, 3 and 4 skipped: a skip of one disparity and runs of skips both occur. Or
      // with disparity 0's batch skipped too: the left state then starts with a skip.
      for (const bool skip_first : {false, true}) {
        const auto searched = [&](int d) {
          const int b = d / batch;
          return b != 1 && b != 3 && b != 4 && !(skip_first && b == 0);
        };
        WtaState expected(w);
        for (int d = 0; d < disparities; d += batch) {
          const int count = std::min(batch, disparities - d);
          if (searched(d))
            scalar::wta_update_row(volume.data() + d * stride, stride, count, w, d, expected.row());
          else
            scalar::wta_skip_row(count, w, d, expected.row());
        }
        for (int x = 0; x < w; ++x) {
          const int winner = expected.disp[x];
          ASSERT_TRUE(winner >= 0 && searched(winner)) << "x " << x << " winner " << winner;
        }
        WtaState reference(w, &rng);
        for (int d = 0; d < disparities; d += batch) {
          const int count = std::min(batch, disparities - d);
          if (searched(d))
            scalar::wta_update_row(volume.data() + d * stride, stride, count, w, d,
                                   reference.row());
          else
            scalar::wta_skip_row(count, w, d, reference.row());
        }
        ASSERT_TRUE(reference == expected) << "scalar, width " << w << " batch " << batch;
        for_each_target([&] {
          WtaState state(w, &rng);
          for (int d = 0; d < disparities; d += batch) {
            const int count = std::min(batch, disparities - d);
            if (searched(d))
              wta_update_row(volume.data() + d * stride, stride, count, w, d, state.row());
            else
              wta_skip_row(count, w, d, state.row());
          }
          ASSERT_TRUE(state == expected) << "width " << w << " batch " << batch;
        });
      }
    }
  }
}

// Column ranges of a row (a windowed search): each range's columns take their costs or skip,
// kNoCost among the costs leaves that disparity out, and the right image's state takes in only
// the costs of the columns updated. The same as the whole row with kNoCost for every cost left
// out, vector or scalar.
TEST(StereoKernels, WinnerTakesAllOverColumnRangesEqualsTheRowWithCostsLeftOut) {
  std::mt19937 rng(37);
  for (const int w : kWidths) {
    const int disparities = std::min(w, 48);
    const std::ptrdiff_t stride = w;
    std::vector<std::uint16_t> volume(static_cast<std::size_t>(stride * disparities));
    for (auto& c : volume) c = static_cast<std::uint16_t>(rng() % 9);
    for (const int batch : {1, 5, 16}) {
      // Per batch three ranges (cuts at random columns): updated, skipped or updated with some
      // costs kNoCost.
      std::vector<std::array<int, 4>> cuts;
      std::vector<std::array<int, 3>> kinds;
      for (int d = 0; d < disparities; d += batch) {
        std::array<int, 4> c{0, static_cast<int>(rng() % (w + 1)),
                             static_cast<int>(rng() % (w + 1)), w};
        std::sort(c.begin(), c.end());
        cuts.push_back(c);
        kinds.push_back({static_cast<int>(rng() % 3), static_cast<int>(rng() % 3),
                         static_cast<int>(rng() % 3)});
      }
      // The costs as the ranged calls see them: kNoCost where a range leaves them out.
      std::vector<std::uint16_t> left_out = volume;
      for (int d = 0, i = 0; d < disparities; d += batch, ++i)
        for (int r = 0; r < 3; ++r)
          for (int k = d; k < std::min(d + batch, disparities); ++k)
            for (int x = cuts[i][r]; x < cuts[i][r + 1]; ++x) {
              if (kinds[i][r] == 1 || (kinds[i][r] == 2 && (x + k) % 3 == 0))
                left_out[k * stride + x] = kNoCost;
            }
      WtaState expected(w);
      for (int d = 0; d < disparities; d += batch)
        scalar::wta_update_row(left_out.data() + d * stride, stride,
                               std::min(batch, disparities - d), w, d, expected.row());
      const auto ranged = [&](auto update, auto skip) {
        WtaState state(w, &rng);
        for (int d = 0, i = 0; d < disparities; d += batch, ++i) {
          const int count = std::min(batch, disparities - d);
          for (int r = 0; r < 3; ++r) {
            const int begin = cuts[i][r], end = cuts[i][r + 1];
            if (kinds[i][r] == 1)
              skip(count, begin, end, d, state.row());
            else
              update(left_out.data() + d * stride, stride, count, begin, end, d, state.row());
          }
        }
        return state;
      };
      const WtaState reference = ranged([](auto... a) { scalar::wta_update_range(a...); },
                                        [](auto... a) { scalar::wta_skip_range(a...); });
      ASSERT_TRUE(reference == expected) << "scalar, width " << w << " batch " << batch;
      for_each_target([&] {
        const WtaState state = ranged([](auto... a) { wta_update_range(a...); },
                                      [](auto... a) { wta_skip_range(a...); });
        ASSERT_TRUE(state == expected) << "width " << w << " batch " << batch;
      });
    }
  }
}

TEST(StereoKernels, LeftRightCheckMatchesScalarAndThePixelRule) {
  std::mt19937 rng(37);
  for (const int w : kWidths) {
    for (const int max_diff : {0, 1, 3}) {
      // Right winners often within a few of the left ones, some invalid; left values invalid,
      // pointing left of the row (d > x) and plain.
      std::vector<std::int16_t> right(static_cast<std::size_t>(w)), left(right.size());
      for (int x = 0; x < w; ++x) {
        right[x] = static_cast<std::int16_t>(rng() % 8 == 0 ? pixel::kInvalid : rng() % 12);
        left[x] = static_cast<std::int16_t>(rng() % 8 == 0 ? pixel::kInvalid : rng() % 14);
      }
      std::vector<std::int16_t> expected = left;
      scalar::left_right_check_row(expected.data(), right.data(), w, max_diff);
      int kept = 0;
      for (int x = 0; x < w; ++x) {
        const bool agree = left[x] != pixel::kInvalid &&
                           pixel::left_right_agree(x, left[x], right.data(), max_diff);
        ASSERT_EQ(expected[x], agree ? left[x] : pixel::kInvalid) << x;
        kept += agree;
      }
      if (w >= 64) {
        ASSERT_GT(kept, 0);  // both outcomes occur
      }
      for_each_target([&] {
        std::vector<std::int16_t> actual = left;
        std::vector<std::int32_t> scratch(static_cast<std::size_t>(w), 12345);
        left_right_check_row(actual.data(), right.data(), w, max_diff, scratch.data());
        ASSERT_EQ(actual, expected) << "width " << w << " max_diff " << max_diff;
      });
    }
  }
}

TEST(StereoKernels, UniquenessCheckMatchesScalarAndThePixelRule) {
  std::mt19937 rng(41);
  for (const int w : kWidths) {
    for (const double keep : {0.85, 0.5, 0.999}) {
      // Second costs near the best ones (both outcomes), kNoCost, and exact ties (keep 0.5 with
      // an even second cost).
      std::vector<std::uint16_t> best(static_cast<std::size_t>(w)), second(best.size());
      std::vector<std::int16_t> disparity(best.size());
      for (int x = 0; x < w; ++x) {
        best[x] = static_cast<std::uint16_t>(rng() % 4000);
        const int kind = static_cast<int>(rng() % 4);
        second[x] = kind == 0   ? kNoCost
                    : kind == 1 ? static_cast<std::uint16_t>(2 * best[x])
                    : kind == 2 ? static_cast<std::uint16_t>(best[x] + rng() % 4)
                                : static_cast<std::uint16_t>(best[x] + rng() % 800);
        disparity[x] = static_cast<std::int16_t>(rng() % 6 == 0 ? pixel::kInvalid : rng() % 300);
      }
      std::vector<std::int16_t> expected = disparity;
      scalar::uniqueness_check_row(expected.data(), best.data(), second.data(), w, keep);
      int kept = 0, dropped = 0;
      for (int x = 0; x < w; ++x) {
        const bool unique = pixel::unique_enough(best[x], second[x], keep);
        ASSERT_EQ(expected[x], unique ? disparity[x] : pixel::kInvalid) << x;
        kept += unique && disparity[x] != pixel::kInvalid;
        dropped += !unique;
      }
      if (w >= 64) {
        ASSERT_GT(kept, 0);
        ASSERT_GT(dropped, 0);
      }
      for_each_target([&] {
        std::vector<std::int16_t> actual = disparity;
        uniqueness_check_row(actual.data(), best.data(), second.data(), w, keep);
        ASSERT_EQ(actual, expected) << "width " << w << " keep " << keep;
      });
    }
  }
}

TEST(StereoKernels, WinnerTakesAllFindsTheMinimumAndItsNeighbours) {
  const int w = 21;
  const std::vector<std::uint16_t> costs = {50, 40, 10, 30, 20, 60};
  for_each_target([&] {
    WtaState state(w);
    for (int d = 0; d < static_cast<int>(costs.size()); ++d) {
      std::vector<std::uint16_t> slice(w, costs[d]);
      wta_update_row(slice.data(), 0, 1, w, d, state.row());
    }
    for (int x = 0; x < w; ++x) {
      ASSERT_EQ(state.disp[x], 2);
      ASSERT_EQ(state.best[x], 10);
      ASSERT_EQ(state.below[x], 40);
      ASSERT_EQ(state.above[x], 30);
      ASSERT_EQ(state.second[x], 20);  // best at least two disparities away
    }
    // Right pixel xr sees left pixel xr + d: only xr < w - d exist at disparity d.
    for (int xr = 0; xr < w - 5; ++xr) ASSERT_EQ(state.disp_right[xr], 2);
  });
}

TEST(StereoKernels, DisparityValuesRowMatchesScalarAndThePixelRule) {
  std::mt19937 rng(23);
  const float inf = std::numeric_limits<float>::infinity();
  // Costs near each other, so that ties, a winner above its neighbours and kNoCost all occur.
  const auto costs = [&](int w) {
    std::vector<std::uint16_t> v = random_vector<std::uint16_t>(rng, w, 500, 504);
    for (auto& e : v)
      if (rng() % 9 == 0) e = kNoCost;
    return v;
  };
  for (const int w : kWidths)
    for (const bool subpixel : {true, false}) {
      const float max_value = 40.0f;
      auto wta = random_vector<std::int16_t>(rng, w, -1, 41);
      auto checked = wta;
      for (auto& d : checked)
        if (rng() % 4 == 0) d = -1;
      const auto voted = random_vector<std::uint8_t>(rng, w, 0, 1);
      const auto below = costs(w), best = costs(w), above = costs(w);
      const DisparityRowInputs in{wta.data(),   checked.data(), voted.data(),
                                  below.data(), best.data(),    above.data()};
      std::vector<float> raw(static_cast<std::size_t>(w), -5.0f), sparse(raw.size(), -5.0f);
      scalar::disparity_values_row(in, w, subpixel, max_value, raw.data(), sparse.data());
      for (int x = 0; x < w; ++x) {
        // The rule: an equiangular offset where the winner is strictly below one neighbour and
        // not above the other; values within [0, max_value]; +inf for no or no positive value.
        const int b = below[x], c = best[x], a = above[x];
        const bool fit =
            subpixel && b != kNoCost && a != kNoCost && b >= c && a >= c && std::max(b, a) > c;
        const float offset = fit ? float(b - a) / (2.0f * float(std::max(b, a) - c)) : 0.0f;
        const float v = std::clamp(float(wta[x]) + offset, 0.0f, max_value);
        ASSERT_EQ(raw[x], v) << x;
        const float s = std::min(float(checked[x]) + (voted[x] ? 0.0f : offset), max_value);
        ASSERT_EQ(sparse[x], checked[x] == -1 || !(s > 0.0f) ? inf : s) << x;
        ASSERT_LE(std::abs(offset), 0.5f);
      }
      for_each_target([&] {
        std::vector<float> out_raw(raw.size(), -5.0f), out_sparse(raw.size(), -5.0f);
        disparity_values_row(in, w, subpixel, max_value, out_raw.data(), out_sparse.data());
        ASSERT_EQ(out_raw, raw) << "width " << w << " subpixel " << subpixel;
        ASSERT_EQ(out_sparse, sparse) << "width " << w << " subpixel " << subpixel;
      });
    }
}

}  // namespace
}  // namespace dco::kernels
