#pragma once

// Rectification as one data-parallel pass: cv::remap's bilinear interpolation of 8-bit images
// through fixed-point maps (CV_16SC2 integer source positions + CV_16UC1 1/32-pixel fractions),
// with the constant border 0. OpenCV's weights for fraction (fx, fy) are (32 - fx) * (32 - fy) *
// 32, fx * (32 - fy) * 32, (32 - fx) * fy * 32 and fx * fy * 32 (exact products of its float table,
// summing to 2^15); the sum is rounded by adding 2^14 and shifting by 15. Taps outside the image
// count as 0, which also makes a position wholly outside it 0, as cv::remap writes there.

#include <cstddef>
#include <cstdint>

#include "dco/gpu/stereo_passes.hpp"
#include "dco/kernels/host_device.hpp"

namespace dco::gpu {
namespace px_remap {

inline constexpr int kFractionBits = 5;
inline constexpr int kWeightBits = 15;

// Channel c of the output pixel whose map entry is (sx, sy, frac); src is tightly packed.
DCO_HD inline std::uint8_t bilinear(const std::uint8_t* src, int width, int height, int channels,
                                    int sx, int sy, unsigned frac, int c) {
  constexpr int kSide = 1 << kFractionBits;
  const int fx = static_cast<int>(frac & (kSide - 1));
  const int fy = static_cast<int>((frac >> kFractionBits) & (kSide - 1));
  const int weights[4] = {(kSide - fx) * (kSide - fy) * kSide, fx * (kSide - fy) * kSide,
                          (kSide - fx) * fy * kSide, fx * fy * kSide};
  int sum = 1 << (kWeightBits - 1);
  for (int k = 0; k < 4; ++k) {
    const int x = sx + (k & 1);
    const int y = sy + (k >> 1);
    if (x >= 0 && y >= 0 && x < width && y < height)
      sum += weights[k] * src[(static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                               static_cast<std::size_t>(x)) *
                                  static_cast<std::size_t>(channels) +
                              static_cast<std::size_t>(c)];
  }
  return static_cast<std::uint8_t>(sum >> kWeightBits);
}

}  // namespace px_remap

namespace passes {

// One output pixel (all its channels) per grid point; maps and images tightly packed.
struct RemapBilinear {
  const std::uint8_t* src;
  const std::int16_t* xy;
  const std::uint16_t* frac;
  std::uint8_t* out;
  int src_width, src_height, channels, width;
  DCO_HD void operator()(int x, int y) const {
    const std::size_t i = at(x, y, width);
    const int sx = xy[2 * i];
    const int sy = xy[2 * i + 1];
    for (int c = 0; c < channels; ++c)
      out[i * static_cast<std::size_t>(channels) + static_cast<std::size_t>(c)] =
          px_remap::bilinear(src, src_width, src_height, channels, sx, sy, frac[i], c);
  }
};

}  // namespace passes
}  // namespace dco::gpu
