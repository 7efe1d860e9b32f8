#include "dco/kernels/boundary_kernels.hpp"
#include "for_each_target.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace dco::kernels {
namespace {

pixel::BoundaryRule rule_with_radius(int radius) {
  pixel::BoundaryRule rule;
  rule.radius = radius;
  rule.keep = 102;
  for (int i = 0; i < 256; ++i)
    rule.weight[i] = static_cast<std::uint16_t>(
        std::lround(pixel::kBoundaryWeightOne * std::exp(-i / pixel::kBoundaryGreyScale)));
  return rule;
}

TEST(BoundaryKernels, SideCostIsThePixelRuleOnEveryPixelAndDisparity) {
  // Rows padded past the width, so a vector that read past a row's end would see other bytes.
  constexpr int kWidth = 29, kHeight = 13, kStride = 37;
  std::mt19937 rng(31);
  std::vector<std::uint8_t> left(kStride * kHeight), right(left.size());
  // Smooth patches and large steps, so that weights span their range and differences hit the cap.
  for (std::size_t i = 0; i < left.size(); ++i) {
    left[i] = static_cast<std::uint8_t>(rng() % 4 == 0 ? rng() % 256 : 100 + rng() % 8);
    right[i] = static_cast<std::uint8_t>(rng() % 4 == 0 ? rng() % 256 : 100 + rng() % 8);
  }
  const pixel::GreyPair im{left.data(), right.data(), kStride, kStride, kWidth, kHeight};
  int vector_windows = 0;
  for (const int radius : {0, 1, 2, 3, 4}) {
    const pixel::BoundaryRule rule = rule_with_radius(radius);
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x) {
        BoundaryWindow window;
        boundary_window(im, x, y, rule, window);
        vector_windows += window.vector;
        for (const int d : {-1, 0, 1, 2, 5, 11, 20, 28, 40}) {
          const std::uint32_t want = pixel::side_cost(im, x, y, d, rule);
          for_each_target([&] {
            ASSERT_EQ(boundary_side_cost(im, window, d, rule), want)
                << "radius " << radius << " pixel " << x << "," << y << " d " << d;
          });
        }
      }
  }
  // The vector path ran: radius 0..3 windows away from the borders.
  EXPECT_GT(vector_windows, 400);
}

// Widths around the lane counts of every target (4 .. 16 float lanes, SVE up to 64) and odd ones.
const std::vector<int> kWidths = {1, 2, 3, 5, 8, 15, 16, 17, 31, 32, 33, 47, 64, 65, 130, 257};

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

TEST(BoundaryKernels, ColumnSidesAreTheExtremesOfTheValuesBelowInfinity) {
  // Values, holes (+inf), NaN (left out too) and -inf (a value, the least there is); columns
  // with no value at all.
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::mt19937 rng(41);
  std::uniform_real_distribution<float> value(0.0f, 60.0f);
  std::uniform_int_distribution<int> kind(0, 9);
  for (const int width : kWidths)
    for (int count = 1; count <= 5; ++count) {
      std::vector<std::vector<float>> rows(static_cast<std::size_t>(count));
      std::vector<const float*> in;
      for (std::vector<float>& r : rows) {
        r.resize(static_cast<std::size_t>(width));
        for (float& v : r) {
          const int k = kind(rng);
          v = k < 3 ? inf : k == 3 ? nan : k == 4 && rng() % 8 == 0 ? -inf : value(rng);
        }
        in.push_back(r.data());
      }
      std::vector<float> far(static_cast<std::size_t>(width)), near(far.size());
      scalar::boundary_column_sides(in.data(), count, width, far.data(), near.data());
      for (int x = 0; x < width; ++x) {
        float lo = inf, hi = -inf;
        for (int k = 0; k < count; ++k) {
          const float v = in[static_cast<std::size_t>(k)][x];
          if (v < inf) lo = std::min(lo, v), hi = std::max(hi, v);
        }
        ASSERT_EQ(far[static_cast<std::size_t>(x)], lo) << "width " << width << " x " << x;
        ASSERT_EQ(near[static_cast<std::size_t>(x)], hi) << "width " << width << " x " << x;
      }
      for_each_target([&] {
        std::vector<float> vfar(far.size(), -1.0f), vnear(far.size(), -1.0f);
        boundary_column_sides(in.data(), count, width, vfar.data(), vnear.data());
        ASSERT_TRUE(same_bits(vfar, far)) << "width " << width << " count " << count;
        ASSERT_TRUE(same_bits(vnear, near)) << "width " << width << " count " << count;
      });
    }
}

TEST(BoundaryKernels, RowSidesAreTheWindowExtremesAtBothReaches) {
  // Column sides padded by the reach with "none", as the refinement gives them; every reach
  // the refinement allows with and without the narrow window.
  const float inf = std::numeric_limits<float>::infinity();
  std::mt19937 rng(43);
  std::uniform_real_distribution<float> value(0.0f, 60.0f);
  for (const int width : kWidths)
    for (const int reach : {2, 3, 4, 7, 16})
      for (const bool narrow : {false, true}) {
        const auto padded = static_cast<std::size_t>(width + 2 * reach);
        std::vector<float> lo(padded, inf), hi(padded, -inf);
        for (int x = 0; x < width; ++x) {
          if (rng() % 4 == 0) continue;  // a column without a value
          const float a = value(rng), b = value(rng);
          lo[static_cast<std::size_t>(x + reach)] = std::min(a, b);
          hi[static_cast<std::size_t>(x + reach)] = std::max(a, b);
        }
        const float* l = lo.data() + reach;
        const float* h = hi.data() + reach;
        const auto n = static_cast<std::size_t>(width);
        std::vector<float> far(n), near(n), nfar(n, -1.0f), nnear(n, -1.0f);
        scalar::boundary_row_sides(l, h, width, reach, 2, far.data(), near.data(),
                                   narrow ? nfar.data() : nullptr, narrow ? nnear.data() : nullptr);
        const auto expect_window = [&](const std::vector<float>& f, const std::vector<float>& g,
                                       int r) {
          for (int x = 0; x < width; ++x) {
            float want_f = inf, want_g = -inf;
            for (int o = -r; o <= r; ++o) want_f = std::min(want_f, l[x + o]);
            for (int o = -r; o <= r; ++o) want_g = std::max(want_g, h[x + o]);
            ASSERT_EQ(f[static_cast<std::size_t>(x)], want_f) << "reach " << r << " x " << x;
            ASSERT_EQ(g[static_cast<std::size_t>(x)], want_g) << "reach " << r << " x " << x;
          }
        };
        expect_window(far, near, reach);
        if (narrow) expect_window(nfar, nnear, 2);
        for_each_target([&] {
          std::vector<float> vfar(n, -1.0f), vnear(n, -1.0f), vnfar(n, -1.0f), vnnear(n, -1.0f);
          boundary_row_sides(l, h, width, reach, 2, vfar.data(), vnear.data(),
                             narrow ? vnfar.data() : nullptr, narrow ? vnnear.data() : nullptr);
          ASSERT_TRUE(same_bits(vfar, far)) << "width " << width << " reach " << reach;
          ASSERT_TRUE(same_bits(vnear, near)) << "width " << width << " reach " << reach;
          ASSERT_TRUE(same_bits(vnfar, nfar)) << "width " << width << " reach " << reach;
          ASSERT_TRUE(same_bits(vnnear, nnear)) << "width " << width << " reach " << reach;
        });
      }
}

}  // namespace
}  // namespace dco::kernels
