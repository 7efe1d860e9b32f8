#pragma once

// The side costs of the boundary refinement (pixel::side_cost) on the CPU: the window's support
// weights are computed once per pixel for all of its candidate disparities, and the weighted
// differences of each window row go by one vector. Integer sums of the same terms, so the
// results are pixel::side_cost's bit for bit.

#include <cstdint>

#include "dco/kernels/boundary_pixel.hpp"

namespace dco::kernels {

struct BoundaryWindow {
  static constexpr int kMaxRadius = 3;  // a row of the window fits eight lanes
  static constexpr int kLanes = 8;
  int x = 0, y = 0;
  // The whole window, and the eight columns from its left end, lie inside the images, and the
  // radius is at most kMaxRadius; otherwise boundary_side_cost is pixel::side_cost.
  bool vector = false;
  int radius = 0;
  // Support weight of each window pixel; 0 past the window's width.
  alignas(16) std::uint16_t weight[2 * kMaxRadius + 1][kLanes] = {};
};

// The window of input pixel (x, y).
void boundary_window(const pixel::GreyPair& im, int x, int y, const pixel::BoundaryRule& rule,
                     BoundaryWindow& window);

// pixel::side_cost(im, window.x, window.y, d, rule).
std::uint32_t boundary_side_cost(const pixel::GreyPair& im, const BoundaryWindow& window, int d,
                                 const pixel::BoundaryRule& rule);

}  // namespace dco::kernels
