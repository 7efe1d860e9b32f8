#include "dco/kernels/filter_kernels.hpp"
#include "for_each_target.hpp"
#include "kernel_test_rows.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "dco/kernels/contour_pixel.hpp"

namespace dco::kernels {
namespace {

const std::vector<int>& kWidths = kLaneWidths;

TEST(FilterKernels, RepeatPairsPutsEveryValueTwice) {
  for (const int width : {0, 1, 2, 7, 8, 33, 64, 1281}) {
    std::vector<float> in(static_cast<std::size_t>((width + 1) / 2));
    for (std::size_t i = 0; i < in.size(); ++i) in[i] = 0.5f * static_cast<float>(i) - 3.0f;
    std::vector<float> out(static_cast<std::size_t>(width) + 1, -99.0f);
    repeat_pairs(in.data(), width, out.data());
    for (int x = 0; x < width; ++x) ASSERT_EQ(out[x], in[x / 2]) << "width " << width << " x " << x;
    EXPECT_EQ(out[width], -99.0f) << "nothing past the row";
  }
}

TEST(FilterKernels, Median5RowMatchesScalarAndTheSortedWindow) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> few(0, 3);
  for_each_target([&] {
    for (const int w : kWidths)
      for (const bool ties : {false, true}) {
        std::vector<float> rows[5];
        const float* pointers[5];
        for (int k = 0; k < 5; ++k) {
          rows[k] = random_floats(rng, w, 0.0f, 200.0f);
          if (ties)
            for (float& e : rows[k]) e = static_cast<float>(few(rng));
          pointers[k] = rows[k].data();
        }
        std::vector<float> columns(static_cast<std::size_t>(median5_columns(w)));
        std::vector<float> expected(static_cast<std::size_t>(w)), actual(expected.size());
        scalar::median5_row(pointers, w, expected.data());
        median5_row(pointers, w, columns.data(), actual.data());
        for (int x = 0; x < w; ++x) {
          ASSERT_EQ(actual[x], expected[x]) << "w " << w << " x " << x << " ties " << ties;
          std::vector<float> window;
          for (int k = 0; k < 5; ++k)
            for (int j = -2; j <= 2; ++j) window.push_back(rows[k][std::clamp(x + j, 0, w - 1)]);
          std::sort(window.begin(), window.end());
          ASSERT_EQ(expected[x], window[12]) << "w " << w << " x " << x;
        }
      }
  });
}

TEST(FilterKernels, GaussianVerticalRowMatchesScalarAndThePixelMath) {
  std::mt19937 rng(1);
  const float taps[3] = {0.1201f, 0.2339f, 0.2920f};
  for_each_target([&] {
    for (const int w : kWidths) {
      const RandomGreyRows input(rng, w);
      const auto& rows = input.rows;
      const auto& pointers = input.pointers;
      std::vector<float> expected(static_cast<std::size_t>(w)), actual(expected.size());
      scalar::gaussian5_vertical_row(pointers, taps, w, expected.data());
      gaussian5_vertical_row(pointers, taps, w, actual.data());
      for (int x = 0; x < w; ++x) {
        ASSERT_EQ(actual[x], expected[x]) << "w " << w << " x " << x;
        // Within rounding only: this file may be compiled with fused multiply-add (aarch64).
        ASSERT_FLOAT_EQ(expected[x], pixel::gaussian5_vertical(rows[0][x], rows[1][x], rows[2][x],
                                                               rows[3][x], rows[4][x], taps));
      }
    }
  });
}

TEST(FilterKernels, RowFilterMatchesScalarAndClampsTheEnds) {
  std::mt19937 rng(2);
  for_each_target([&] {
    for (const int w : kWidths)
      for (const int radius : {0, 1, 2, 4, 9}) {
        const std::vector<float> in = random_floats(rng, w, -10.0f, 10.0f);
        const std::vector<float> taps = random_floats(rng, 2 * radius + 1, 0.0f, 1.0f);
        std::vector<float> expected(static_cast<std::size_t>(w)), actual(expected.size());
        scalar::row_filter(in.data(), w, taps.data(), radius, expected.data());
        row_filter(in.data(), w, taps.data(), radius, actual.data());
        for (int x = 0; x < w; ++x) {
          ASSERT_EQ(actual[x], expected[x]) << "w " << w << " radius " << radius << " x " << x;
          // The reference, written out: taps over the row with its ends repeated.
          float sum = 0.0f;
          for (int k = 0; k <= 2 * radius; ++k)
            sum += taps[k] * in[std::clamp(x + k - radius, 0, w - 1)];
          ASSERT_NEAR(expected[x], sum, 1e-5f * (1.0f + std::abs(sum))) << "w " << w << " x " << x;
        }
      }
  });
}

TEST(FilterKernels, BoxVerticalRowMatchesScalarAndTheColumnMean) {
  std::mt19937 rng(3);
  for_each_target([&] {
    for (const int w : kWidths)
      for (const int size : {1, 3, 9})
        for (const int h : {1, 4, 12}) {
          // Rows padded to a stride longer than the width, as an image's are.
          const int stride = w + 5;
          const std::vector<float> image = random_floats(rng, stride * h, 0.0f, 1.0f);
          const float inv = 1.0f / static_cast<float>(size);
          for (int y = 0; y < h; ++y) {
            std::vector<float> expected(static_cast<std::size_t>(w)), actual(expected.size());
            scalar::box_vertical_row(image.data(), stride, h, y, size, inv, w, expected.data());
            box_vertical_row(image.data(), stride, h, y, size, inv, w, actual.data());
            for (int x = 0; x < w; ++x) {
              ASSERT_EQ(actual[x], expected[x])
                  << "w " << w << " h " << h << " size " << size << " y " << y << " x " << x;
              // The mean written out: the rows of the window, clamped to the image, in order.
              float t = 0.0f;
              for (int k = 0; k < size; ++k)
                t = (k == 0 ? 0.0f : t) +
                    image[std::clamp(y - size / 2 + k, 0, h - 1) * stride + x];
              ASSERT_EQ(expected[x], t * inv);
            }
          }
        }
  });
}

TEST(FilterKernels, SobelRowMatchesScalarAndThePixelMath) {
  std::mt19937 rng(4);
  // Few distinct levels: zero and equal gradients (the sector borders' ties) happen often.
  std::uniform_int_distribution<int> level(0, 4);
  for_each_target([&] {
    for (const int w : kWidths) {
      std::vector<float> rows[3];
      for (auto& r : rows) {
        r.resize(static_cast<std::size_t>(w));
        for (float& e : r) e = 16.0f * static_cast<float>(level(rng));
      }
      const SobelRows in{rows[0].data(), rows[1].data(), rows[2].data(), w};
      std::vector<float> m_expected(static_cast<std::size_t>(w)), m_actual(m_expected.size());
      std::vector<std::uint8_t> d_expected(m_expected.size()), d_actual(m_expected.size());
      scalar::sobel_row(in, 1.0f / 1443.0f, m_expected.data(), d_expected.data());
      sobel_row(in, 1.0f / 1443.0f, m_actual.data(), d_actual.data());
      for (int x = 0; x < w; ++x) {
        ASSERT_EQ(m_actual[x], m_expected[x]) << "w " << w << " x " << x;
        ASSERT_EQ(d_actual[x], d_expected[x]) << "w " << w << " x " << x;
        const int l = std::max(x - 1, 0), r = std::min(x + 1, w - 1);
        const float gx = pixel::sobel_gx(in.up, in.mid, in.down, l, r);
        const float gy = pixel::sobel_gy(in.up, in.down, l, x, r);
        ASSERT_EQ(m_expected[x], pixel::gradient_magnitude(gx, gy, 1.0f / 1443.0f));
        ASSERT_EQ(d_expected[x], pixel::gradient_direction(gx, gy));
      }
    }
  });
}

TEST(FilterKernels, SobelDirectionsFollowTheGradient) {
  // A horizontal ramp (gradient along x), a vertical one, and the two diagonals.
  const int w = 40;
  std::vector<float> up(w), mid(w), down(w);
  const auto run = [&](auto value) {
    for (int x = 0; x < w; ++x) up[x] = value(x, -1), mid[x] = value(x, 0), down[x] = value(x, 1);
    std::vector<float> m(w);
    std::vector<std::uint8_t> d(w);
    sobel_row({up.data(), mid.data(), down.data(), w}, 1.0f, m.data(), d.data());
    return d[w / 2];
  };
  EXPECT_EQ(run([](int x, int) { return 3.0f * x; }), 0);
  EXPECT_EQ(run([](int, int y) { return 3.0f * y; }), 2);
  EXPECT_EQ(run([](int x, int y) { return 3.0f * (x + y); }), 1);
  EXPECT_EQ(run([](int x, int y) { return 3.0f * (x - y); }), 3);
}

}  // namespace
}  // namespace dco::kernels
