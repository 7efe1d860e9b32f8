#pragma once

// The boundary refinement on the CPU. The side costs (pixel::side_cost): the window's support
// weights are computed once per pixel for all of its candidate disparities, and the weighted
// differences of each window row go by one vector. Integer sums of the same terms, so the
// results are pixel::side_cost's bit for bit. The sides around each internal pixel
// (pixel::side_range), separably: across the rows first, then along the row.

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

// far[x] = the least and near[x] = the greatest of rows[0][x] .. rows[count - 1][x], taken row by
// row as `v < far ? v : far` (`v > near ? v : near`) over the values below +inf only (the
// sparse map's "none" and NaN left out): +inf and -inf where a column holds no value.
void boundary_column_sides(const float* const* rows, int count, int width, float* far, float* near);
// far[x] = the least of lo[x - reach .. x + reach] and near[x] = the greatest of hi[x - reach ..
// x + reach], for x < width; lo and hi (boundary_column_sides' far and near) are read from index
// -reach to width + reach - 1. With narrow_far (and narrow_near), those over narrow_reach
// (<= reach) too. Each window is folded as `b < v ? b : v` (`b > v ? b : v`): the narrow
// one's columns left to right, then the wider one's other columns left to right.
void boundary_row_sides(const float* lo, const float* hi, int width, int reach, int narrow_reach,
                        float* far, float* near, float* narrow_far, float* narrow_near);

namespace scalar {
void boundary_column_sides(const float* const* rows, int count, int width, float* far, float* near);
void boundary_row_sides(const float* lo, const float* hi, int width, int reach, int narrow_reach,
                        float* far, float* near, float* narrow_far, float* narrow_near);
}  // namespace scalar

}  // namespace dco::kernels
