#pragma once

#include <cstdint>

#include "dco/core/image.hpp"
#include "dco/pipeline/stereo/exposure_balance.hpp"

namespace dco::stereo {

// A rectified pair whose calibration has drifted (a cheap module warms up, its mount flexes) no
// longer has its matches on the same row: the right image's scene point lies `offset` rows below
// the left's. Half a row already costs the dense map 2.6 points of bad-2 on the shared scenes,
// one row 9.9 (bench/RESULTS.md, "Vertical alignment between the two cameras").
//
// Fits that offset from the pairs a disparity map gives: matched left pixels (4,096 looked at)
// with a vertical grey step of at least 8 levels, against the right image at (x - d, y + offset)
// (bilinear, its levels through `levels`), by a Gauss-Newton step on the squared difference from
// `offset` (pairs more than 40 levels apart left out). With `search`, three steps from the most
// common best row of 5x5 windows searched over -3 .. +3 rows and -2 .. +2 columns around the
// matches with grey steps both ways. Returns false, leaving `offset` as it was, with fewer than
// kMinAlignmentPairs pairs or an offset beyond kMaxVerticalOffset.
inline constexpr int kMinAlignmentPairs = 100;
inline constexpr double kMaxVerticalOffset = 4.0;
bool fit_vertical_offset(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                         ImageView<const float> disparity, const ExposureMap& levels, bool search,
                         double& offset);

// out(x, y) = right(x, y + offset), linear between rows (8-bit weights), the first and last rows
// repeated beyond the image. `out` is resized to `right`.
void shift_rows(ImageView<const std::uint8_t> right, double offset, Image<std::uint8_t>& out);

}  // namespace dco::stereo
