#pragma once

// The matched pixel pairs that the camera corrections are fitted to (exposure_balance.cpp,
// lens_falloff.cpp): a matched left pixel against the right image at x - d, per channel, where
// both lie on flat ground along their rows and neither is saturated.

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "dco/core/image.hpp"

namespace dco::stereo::detail {

// The right camera's gain against the left's that the exposure and fall-off fits accept: two
// cameras with their own auto-exposure can be more than twice apart; past four times one of them
// has too few levels left for a match to tell.
inline constexpr double kMinRightGain = 0.25, kMaxRightGain = 4.0;
inline constexpr int kFlatRange = 6;  // levels three row neighbours may span to count as flat
inline constexpr double kFitSamples = 16384;  // pixels a fit looks at first (every fourth row
                                              // and column of 640x360; every eighth at 1280x720)

// The level at (x, y) of channel k when it and its row neighbours are within kFlatRange levels
// and unsaturated, else -1. Where the row is flat, a match a pixel off along it (the only way a
// rectified match can be off) still reads the same level, so the pairs carry the cameras'
// difference and not the matcher's sub-pixel error.
inline int flat_level(ImageView<const std::uint8_t> image, int x, int y, int k) {
  const int c = image.channels;
  const std::uint8_t* row = image.row(y);
  const int a = row[(x - 1) * c + k], v = row[x * c + k], b = row[(x + 1) * c + k];
  const int low = std::min({a, v, b}), high = std::max({a, v, b});
  if (high - low > kFlatRange || low == 0 || high == 255) return -1;
  return v;
}

// The step between the rows and columns a fit looks at: about kFitSamples pixels.
inline int fit_step(int width, int height) {
  const double pixels = static_cast<double>(width) * height;
  return std::max(2, static_cast<int>(std::ceil(std::sqrt(pixels / kFitSamples))));
}

// Calls pair(k, x, y, xr, left_level, right_level) for every flat pair of every `step`-th row and
// column, channels 0 .. min(channels, 3) - 1.
template <class Pair>
void for_each_flat_pair(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                        ImageView<const float> disparity, int step, Pair&& pair) {
  const int c = std::min(left.channels, 3);
  const int w = left.width;
  for (int y = 0; y < left.height; y += step) {
    const float* d = disparity.row(y);
    for (int x = 1; x + 1 < w; x += step) {
      // +inf (no match) and NaN fail this test; the match's row neighbours must lie inside the
      // right image. `at` is positive here, so adding a half rounds it.
      const float at = static_cast<float>(x) - d[x];
      if (!(at >= 0.5f && at < static_cast<float>(w) - 1.5f)) continue;
      const int xr = static_cast<int>(at + 0.5f);
      for (int k = 0; k < c; ++k) {
        const int lv = flat_level(left, x, y, k);
        if (lv < 0) continue;
        const int rv = flat_level(right, xr, y, k);
        if (rv < 0) continue;
        pair(k, x, y, xr, lv, rv);
      }
    }
  }
}

}  // namespace dco::stereo::detail
