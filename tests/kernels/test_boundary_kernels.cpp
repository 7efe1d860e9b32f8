#include "dco/kernels/boundary_kernels.hpp"
#include "for_each_target.hpp"

#include <cmath>
#include <cstdint>
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

}  // namespace
}  // namespace dco::kernels
