#include "dco/kernels/flow_kernels.hpp"

#include <cmath>
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
