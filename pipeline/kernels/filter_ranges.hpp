#pragma once

// The scalar image filters over a range of columns: the whole row for dco::kernels::scalar, the
// borders and the last partial vector for the SIMD versions. The order of the float operations
// here (kernels::pixel's) is the contract the vector code follows.

#include <algorithm>

#include "dco/kernels/contour_pixel.hpp"
#include "dco/kernels/filter_kernels.hpp"

namespace dco::kernels::detail {

// The 13th smallest of the 25 values around column x (columns clamped to the row).
inline void median5_range(const float* const rows[5], int width, int begin, int end, float* out) {
  for (int x = begin; x < end; ++x) {
    float window[25];
    for (int i = 0; i < 5; ++i)
      for (int j = 0; j < 5; ++j) window[5 * i + j] = rows[i][std::clamp(x + j - 2, 0, width - 1)];
    std::nth_element(window, window + 12, window + 25);
    out[x] = window[12];
  }
}

inline void gaussian5_vertical_range(const std::uint8_t* const rows[5], const float* taps,
                                     int begin, int end, float* out) {
  for (int x = begin; x < end; ++x)
    out[x] =
        pixel::gaussian5_vertical(rows[0][x], rows[1][x], rows[2][x], rows[3][x], rows[4][x], taps);
}

inline void row_filter_range(const float* in, int width, const float* taps, int radius, int begin,
                             int end, float* out) {
  const auto tap = [taps](int k) { return taps[k]; };
  for (int x = begin; x < end; ++x) out[x] = pixel::clamped_tap_sum(in, width, x, radius, tap);
}

inline void box_vertical_range(const float* in, std::ptrdiff_t stride, int height, int y, int size,
                               float inv, int begin, int end, float* out) {
  for (int x = begin; x < end; ++x)
    out[x] = pixel::box_column_mean(in + x, stride, height, y, size, inv);
}

inline void sobel_range(const SobelRows& r, float inv_norm, int begin, int end, float* magnitude,
                        std::uint8_t* direction) {
  for (int x = begin; x < end; ++x) {
    const int l = std::max(x - 1, 0);
    const int rr = std::min(x + 1, r.width - 1);
    const float gx = pixel::sobel_gx(r.up, r.mid, r.down, l, rr);
    const float gy = pixel::sobel_gy(r.up, r.down, l, x, rr);
    magnitude[x] = pixel::gradient_magnitude(gx, gy, inv_norm);
    direction[x] = pixel::gradient_direction(gx, gy);
  }
}

}  // namespace dco::kernels::detail
