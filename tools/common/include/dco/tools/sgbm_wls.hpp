#pragma once

#include <cstdint>

#include "dco/core/image.hpp"

// The baseline dco is measured against: OpenCV's semi-global matcher followed by its
// weighted-least-squares disparity filter (the "disparity_filtering" recipe from opencv_contrib).
namespace dco::tools {

struct BaselineResult {
  Image<float> disparity;  // px at the input resolution, +inf where the filter gives no value
  double time_ms = 0;      // both matchers + the filter, wall clock
};

// StereoSGBM in MODE_SGBM_3WAY (numDisparities = max_disp rounded up to a multiple of 16,
// blockSize 5, P1 = 8*cn*25, P2 = 32*cn*25, uniquenessRatio 10, speckleWindowSize 100,
// speckleRange 2, disp12MaxDiff 1, preFilterCap 63) for the left and the right view, then
// DisparityWLSFilter (lambda 8000, sigmaColor 1.5) guided by the left image.
// `left` and `right`: 8-bit, same size, 1 or 3 channels. Throws dco::Error on bad input.
BaselineResult run_sgbm_wls(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                            int max_disp);

}  // namespace dco::tools
