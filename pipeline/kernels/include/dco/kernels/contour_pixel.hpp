#pragma once

// Per-pixel math of the contour stage (dco/pipeline/contour), shared by the CPU functions and the
// GPU passes. Float operations in one fixed order and no fused multiply-add (the CPU code is
// built without contraction; dco_gpu compiles with --fmad=false), so both sides give the same bits.

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "dco/kernels/canny_kernels.hpp"
#include "dco/kernels/host_device.hpp"
#include "dco/kernels/stereo_pixel.hpp"

namespace dco::kernels::pixel {

// Vertical pass of the 5-tap Gaussian: rows y-2 .. y+2 of one column (clamped by the caller).
DCO_HD inline float gaussian5_vertical(float a, float b, float c, float d, float e,
                                       const float* taps) {
  return taps[0] * (a + e) + taps[1] * (b + d) + taps[2] * c;
}

// A symmetric filter along a row: sum of tap(k) * row[x + k - radius], clamped to the row,
// accumulated tap by tap from 0 (the CPU's horizontal pass does the same in its interior).
template <class Tap>
DCO_HD float clamped_tap_sum(const float* row, int width, int x, int radius, const Tap& tap) {
  float s = 0.0f;
  for (int k = 0; k < 2 * radius + 1; ++k)
    s += tap(k) * row[clamp_to(x + k - radius, 0, width - 1)];
  return s;
}

// Mean of `size` rows of one column, rows clamped to [0, height): the first row, then each
// further one added in order, then scaled by inv = 1 / size.
DCO_HD inline float box_column_mean(const float* column, std::ptrdiff_t stride, int height, int y,
                                    int size, float inv) {
  const int top = y - size / 2;
  float t = column[clamp_to(top, 0, height - 1) * stride];
  for (int k = 1; k < size; ++k) t += column[clamp_to(top + k, 0, height - 1) * stride];
  return t * inv;
}

// Sobel derivatives at column x from three rows; l and r are x's clamped neighbours.
DCO_HD inline float sobel_gx(const float* up, const float* mid, const float* down, int l, int r) {
  return (up[r] + 2 * mid[r] + down[r]) - (up[l] + 2 * mid[l] + down[l]);
}
DCO_HD inline float sobel_gy(const float* up, const float* down, int l, int x, int r) {
  return (down[l] + 2 * down[x] + down[r]) - (up[l] + 2 * up[x] + up[r]);
}
DCO_HD inline float gradient_magnitude(float gx, float gy, float inv_norm) {
  return std::sqrt(gx * gx + gy * gy) * inv_norm;
}

// The gradient direction in 4 sectors (dco::contour::GradientDirection): 0 horizontal,
// 1 diagonal down, 2 vertical, 3 diagonal up. Branch-free: on texture the direction is close to
// random, and mispredicted branches would cost more than the gradient.
inline constexpr float kTan22 = 0.41421356f;  // tan(22.5°): the sector borders
inline constexpr float kTan67 = 2.41421356f;  // tan(67.5°)
DCO_HD inline std::uint8_t gradient_direction(float gx, float gy) {
  const float ax = std::fabs(gx);
  const float ay = std::fabs(gy);
  const int horizontal = ay <= ax * kTan22;
  const int vertical = ay >= ax * kTan67;
  const int diagonal = 1 + 2 * ((gx > 0) != (gy > 0));
  return static_cast<std::uint8_t>((1 - horizontal) * (vertical * 2 + (1 - vertical) * diagonal));
}

// |q - d|, or 0 when either is missing: inf - finite, inf - inf and anything with NaN all fail
// the comparison.
DCO_HD inline float disparity_jump(float q, float d) {
  constexpr float kMaxFloat = 3.40282347e+38f;
  const float diff = std::fabs(q - d);
  return diff <= kMaxFloat ? diff : 0.0f;
}

// Strength of a depth edge at a pixel of disparity d: the largest jump to its 4 neighbours
// (a neighbour outside the image is the pixel itself) times inv = 1 / full jump, at most 1.
DCO_HD inline float jump_strength(float d, float left, float right, float up, float down,
                                  float inv) {
  const float a = disparity_jump(left, d), b = disparity_jump(right, d);
  const float c = disparity_jump(up, d), e = disparity_jump(down, d);
  const float ab = a < b ? b : a, ce = c < e ? e : c;
  const float j = (ab < ce ? ce : ab) * inv;
  return 1.0f < j ? 1.0f : j;
}

// The gate (internal resolution, gate_size columns or rows) for image column or row i of `size`.
// An internal frame of size / k for a whole k (1 or 2 in the pipeline), rounded down, has cell g
// over image pixels k g .. k g + k - 1, as the matcher's own output (an odd last pixel takes the
// last cell); any other ratio samples at i * gate_size / size, rounded down.
DCO_HD inline int gate_sample(int i, int size, int gate_size) {
  const int k = size / gate_size;
  if (k >= 1 && size - k * gate_size < k) {
    const int g = i / k;
    return g < gate_size - 1 ? g : gate_size - 1;
  }
  return static_cast<int>(static_cast<long long>(i) * gate_size / size);
}

// Non-maximum suppression, depth gate and dual threshold of one interior pixel x of a row
// (see canny_classify_row); `gate` is the pixel's gate value (ignored when !gated).
DCO_HD inline std::uint8_t canny_class(const float* above, const float* row, const float* below,
                                       std::uint8_t direction, bool gated, float gate, int x,
                                       const CannyLevels& t) {
  const float v = row[x];
  if (v < t.low) return kCannyNone;
  if (gated && gate < t.depth) return kCannyNone;
  float before = 0, after = 0;
  switch (direction) {
    case 0:
      before = row[x - 1], after = row[x + 1];
      break;
    case 1:
      before = above[x - 1], after = below[x + 1];
      break;
    case 2:
      before = above[x], after = below[x];
      break;
    default:
      before = below[x - 1], after = above[x + 1];
      break;
  }
  if (!(v > before && v >= after)) return kCannyNone;
  return v > t.high ? kCannyStrong : kCannyWeak;
}

}  // namespace dco::kernels::pixel
