#pragma once

#include <cstdint>

#include "dco/core/image.hpp"

namespace dco::stereo {

// Mean of each 2x2 block, rounded (cv::INTER_AREA at scale 1/2): out is (w/2) x (h/2) with the
// same channels; an odd last column or row is dropped.
void downsample_half(ImageView<const std::uint8_t> in, ImageView<std::uint8_t> out);

// BGR to luma with OpenCV's fixed-point weights (0.114, 0.587, 0.299 in Q15, rounded), so the
// result equals cv::cvtColor(COLOR_BGR2GRAY) bit for bit.
void bgr_to_gray(ImageView<const std::uint8_t> bgr, ImageView<std::uint8_t> gray);

}  // namespace dco::stereo
