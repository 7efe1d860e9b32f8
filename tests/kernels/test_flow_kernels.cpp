#include "dco/kernels/flow_kernels.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "for_each_target.hpp"

namespace dco::kernels {
namespace {

// A flow field with still pixels (below the direction threshold), slow ones and fast ones whose
// samples fall past every border, in a buffer wider than the field.
std::vector<float> random_field(std::mt19937& rng, int w, int h, std::ptrdiff_t stride) {
  std::uniform_real_distribution<float> fast(-40.0f, 40.0f), slow(-0.02f, 0.02f);
  std::vector<float> f(static_cast<std::size_t>(stride * h), 1234.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool still = rng() % 5 == 0;
      f[y * stride + 2 * x] = still ? slow(rng) : fast(rng);
      f[y * stride + 2 * x + 1] = still ? slow(rng) : fast(rng);
    }
  return f;
}

TEST(FlowKernels, ProjectionContrastRowMatchesScalar) {
  std::mt19937 rng(31);
  for (const int w : {1, 2, 5, 16, 17, 33, 70})
    for (const int h : {1, 3, 9}) {
      const std::ptrdiff_t stride = 2 * w + 6;
      const std::vector<float> data = random_field(rng, w, h, stride);
      const FlowField field{data.data(), stride, w, h};
      for (const float distance : {2.0f, 5.5f})
        for (int y = 0; y < h; ++y) {
          std::vector<float> expected(static_cast<std::size_t>(w), -1.0f);
          scalar::projection_contrast_row(field, y, distance, 1e-2f, expected.data());
          for_each_target([&] {
            std::vector<float> out(expected.size(), -1.0f);
            projection_contrast_row(field, y, distance, 1e-2f, out.data());
            for (int x = 0; x < w; ++x)
              ASSERT_EQ(std::signbit(out[x]), std::signbit(expected[x]))
                  << w << "x" << h << " at " << x << "," << y;
            ASSERT_EQ(out, expected) << w << "x" << h << " row " << y << " distance " << distance;
          });
        }
    }
}

TEST(FlowKernels, FlowTargetsRowMatchesScalar) {
  std::mt19937 rng(37);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (const int w : {1, 2, 5, 15, 16, 17, 33, 70})
    for (const int h : {1, 3, 9}) {
      const std::ptrdiff_t stride = 2 * w + 6;
      std::vector<float> data = random_field(rng, w, h, stride);
      // Flows that are not numbers, land exactly on the field's edges or just past them.
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          float* p = data.data() + y * stride + 2 * x;
          switch (rng() % 8) {
            case 0:
              p[rng() % 2] = nan;
              break;
            case 1:
              p[0] = static_cast<float>(w - x) - 0.5f;
              break;  // tx = w
            case 2:
              p[0] = -static_cast<float>(x) - 0.5f;
              break;  // tx = 0
            case 3:
              p[1] = static_cast<float>(h - y) - 0.5f;
              break;  // ty = h
            case 4:
              p[1] = -static_cast<float>(y) - 0.5000001f;
              break;  // just above
            case 5:
              p[0] = std::numeric_limits<float>::infinity();
              break;
            default:
              break;
          }
        }
      const FlowField field{data.data(), stride, w, h};
      for (int y = 0; y < h; ++y) {
        std::vector<std::int32_t> column(static_cast<std::size_t>(w)), row(column.size());
        std::vector<float> speed(column.size());
        scalar::flow_targets_row(field, y, column.data(), row.data(), speed.data());
        for (int x = 0; x < w; ++x) {
          // The reference itself: the nearest pixel inside the field, or none.
          const float u = data[y * stride + 2 * x], v = data[y * stride + 2 * x + 1];
          const double tx = std::floor(static_cast<double>(x) + u + 0.5);
          const double ty = std::floor(static_cast<double>(y) + v + 0.5);
          if (column[x] >= 0) {
            ASSERT_LT(column[x], w);
            ASSERT_GE(row[x], 0);
            ASSERT_LT(row[x], h);
            ASSERT_NEAR(column[x], tx, 1.0) << x;  // float rounding of x + u + 0.5 aside
            ASSERT_NEAR(row[x], ty, 1.0) << x;
          } else {
            ASSERT_EQ(column[x], -1);
          }
          if (std::isnan(u) || std::isnan(v)) {
            ASSERT_EQ(column[x], -1);
          }
        }
        for_each_target([&] {
          std::vector<std::int32_t> c2(column.size(), 7), r2(column.size(), 7);
          std::vector<float> s2(column.size(), 7.0f);
          flow_targets_row(field, y, c2.data(), r2.data(), s2.data());
          ASSERT_EQ(c2, column) << w << "x" << h << " row " << y;
          ASSERT_EQ(r2, row) << w << "x" << h << " row " << y;
          for (int x = 0; x < w; ++x)
            ASSERT_TRUE(s2[x] == speed[x] || (std::isnan(s2[x]) && std::isnan(speed[x])))
                << w << "x" << h << " at " << x << "," << y;
        });
      }
    }
}

// A flow that grows along its own direction (a uniform expansion to the right) has a positive
// contrast, a still field none.
TEST(FlowKernels, ProjectionContrastSeesAnExpansion) {
  const int w = 40, h = 5;
  std::vector<float> data(static_cast<std::size_t>(2 * w * h));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) data[y * 2 * w + 2 * x] = 1.0f + 0.25f * static_cast<float>(x);
  const FlowField field{data.data(), 2 * w, w, h};
  for_each_target([&] {
    std::vector<float> out(static_cast<std::size_t>(w));
    projection_contrast_row(field, 2, 2.0f, 1e-2f, out.data());
    for (int x = 2; x < w - 2; ++x) ASSERT_FLOAT_EQ(out[x], 0.25f * 4.0f) << x;
    std::vector<float> still(data.size(), 0.0f);
    projection_contrast_row({still.data(), 2 * w, w, h}, 2, 2.0f, 1e-2f, out.data());
    for (int x = 0; x < w; ++x) ASSERT_EQ(out[x], 0.0f) << x;
  });
}

}  // namespace
}  // namespace dco::kernels
