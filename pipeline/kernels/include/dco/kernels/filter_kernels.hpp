#pragma once

// Row kernels of the contour stage's image filters (dco/pipeline/contour/separable_filters.hpp
// and the Sobel gradient of the gated Canny) and of the 5x5 median of the densifier's output
// (an order statistic: min and max only, so every target gives the same values). Dispatched at run
// time like the other kernels; dco::kernels::scalar holds the references, whose per-pixel math is
// kernels::pixel's (shared with the GPU passes). The vector versions do the same float operations
// in the same order, no fused multiply-add, so all of them give the same bits.

#include <cstddef>
#include <cstdint>

namespace dco::kernels {

// Vertical pass of the 5-tap Gaussian over one output row: out[x] =
// pixel::gaussian5_vertical(rows[0][x], ..., rows[4][x], taps) for x < width, rows y - 2 .. y + 2
// (clamped by the caller).
void gaussian5_vertical_row(const std::uint8_t* const rows[5], const float* taps, int width,
                            float* out);

// A symmetric filter of `2 radius + 1` taps along one row, the row clamped at its ends:
// out[x] = Σ_k taps[k] * in[x + k - radius], summed tap by tap from 0 (pixel::clamped_tap_sum).
// out may not alias in.
void row_filter(const float* in, int width, const float* taps, int radius, float* out);

// Row y of a box filter's vertical pass over an image of `height` rows `stride` floats apart:
// out[x] = pixel::box_column_mean(in + x, stride, height, y, size, inv) for x < width, the mean
// of rows y - size / 2 .. y + size / 2 (clamped to the image) added in that order.
void box_vertical_row(const float* in, std::ptrdiff_t stride, int height, int y, int size,
                      float inv, int width, float* out);

// Sobel gradient of one row from the rows above and below it (the row itself for the image's
// first and last rows): magnitude[x] = pixel::gradient_magnitude(gx, gy, inv_norm) and
// direction[x] = pixel::gradient_direction(gx, gy), columns clamped at the ends.
struct SobelRows {
  const float* up = nullptr;
  const float* mid = nullptr;
  const float* down = nullptr;
  int width = 0;
};
void sobel_row(const SobelRows& rows, float inv_norm, float* magnitude, std::uint8_t* direction);

// out[x] = in[x / 2] for x < width: a row at half the width (the stereo stage's internal
// resolution) repeated to the full width. A plain loop the compiler vectorises, not dispatched.
void repeat_pairs(const float* in, int width, float* out);

// Row y of the 5x5 median of a float image, its borders replicated: out[x] = the 13th smallest
// of rows[i][clamp(x + j - 2, 0, width - 1)], i and j in 0..4, with rows y - 2 .. y + 2 (clamped
// by the caller). Finite values only (min and max decide the order). `columns` is scratch of
// median5_columns(width) floats.
inline constexpr int median5_columns(int width) {
  return 10 * ((width + 5) / 2 + 1);
}
void median5_row(const float* const rows[5], int width, float* columns, float* out);

namespace scalar {
void median5_row(const float* const rows[5], int width, float* out);
void gaussian5_vertical_row(const std::uint8_t* const rows[5], const float* taps, int width,
                            float* out);
void row_filter(const float* in, int width, const float* taps, int radius, float* out);
void box_vertical_row(const float* in, std::ptrdiff_t stride, int height, int y, int size,
                      float inv, int width, float* out);
void sobel_row(const SobelRows& rows, float inv_norm, float* magnitude, std::uint8_t* direction);
}  // namespace scalar

}  // namespace dco::kernels
