#pragma once

#include <array>
#include <cstdint>

#include "dco/core/image.hpp"

// Small separable filters of the contour stage, written out so that the per-frame path never
// allocates (OpenCV's filter engines build and free their buffers on every call). Borders replicate
// the edge pixel, as cv::BORDER_REPLICATE.
namespace dco::contour {

// Taps of that blur: cv::getGaussianKernel(5, 1.4, CV_32F).
const std::array<float, 5>& gaussian5_taps();

// 5x5 Gaussian with sigma 1.4 (the classic Canny pre-filter) from 8-bit grey to float.
// `tmp` and `out` have the size of `in`; all single-channel.
void gaussian_blur_5x5(ImageView<const std::uint8_t> in, ImageView<float> tmp,
                       ImageView<float> out);
// Its row y alone: the vertical pass into `tmp_row`, then the horizontal one into `out_row`
// (rows of in.width floats).
void gaussian_blur_5x5_row(ImageView<const std::uint8_t> in, int y, float* tmp_row, float* out_row);

// Normalised (mean) box filter of odd `size`. `tmp` and `out` have the size of `in`; `out` may not
// alias `in`.
void box_filter(ImageView<const float> in, int size, ImageView<float> tmp, ImageView<float> out);
// Its two passes for rows [y_begin, y_end): the vertical means into `tmp` (reading the rows
// within size / 2), then the horizontal means of `tmp` into `out`.
void box_vertical_rows(ImageView<const float> in, int size, int y_begin, int y_end,
                       ImageView<float> tmp);
void box_horizontal_rows(ImageView<const float> tmp, int size, int y_begin, int y_end,
                         ImageView<float> out);

}  // namespace dco::contour
