#pragma once

#include <cstdint>

#include "dco/core/image.hpp"
#include "dco/pipeline/stereo/exposure_balance.hpp"

namespace dco::stereo {

// A rectified pair whose calibration has drifted (a cheap module warms up, its mount flexes) no
// longer has its matches on the same row. Half a row already costs the dense map 2.6 points of
// bad-2 on the shared scenes, one row 9.9; a roll that leaves the side edges one row apart, 4.3
// (bench/RESULTS.md, "Vertical alignment between the two cameras", "A roll between the cameras").
//
// The right image's scene point of left pixel (x, y) lies `offset` rows below it, turned by `roll`
// radians about the image centre (xc, yc): at column x it lies offset + roll * (x - xc) rows lower,
// and roll * (y - yc) columns further left.
struct RowAlignment {
  double offset = 0;
  double roll = 0;
  bool operator==(const RowAlignment&) const = default;
  bool identity() const { return offset == 0 && roll == 0; }
};

// Fits that alignment from the pairs a disparity map gives. Without `search`, one Gauss-Newton
// step from `alignment`: matched left pixels (4,096 looked at) with a vertical grey step of at
// least 8 levels, against the right image where `alignment` puts them (bilinear, its levels
// through `levels`), on the squared difference (pairs more than 40 levels apart left out); the
// roll is fitted when the samples spread across the columns, else kept. With `search` (for a
// pair whose rows may lie far from `alignment`), no steps: each of 16,384 sampled matches with
// grey steps both ways finds the whole row (-5 .. +5) and column (-2 .. +2 around the match) at
// which a 5x5 window of the right image differs least from the left's, refined between rows by
// Lucas-Kanade steps; a line through the most common row of each quarter of the columns, then
// through the samples near it, gives the offset and the roll. Returns false, leaving `alignment`
// as it was, with too few samples or rows beyond kMaxVerticalOffset (the offset, or the roll at
// the side edges).
inline constexpr int kMinAlignmentPairs = 100;
inline constexpr double kMaxVerticalOffset = 4.0;
bool fit_row_alignment(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                       ImageView<const float> disparity, const ExposureMap& levels, bool search,
                       RowAlignment& alignment);

// out(x, y) = right(x, y + offset), linear between rows (8-bit weights), the first and last rows
// repeated beyond the image. `out` is resized to `right`.
void shift_rows(ImageView<const std::uint8_t> right, double offset, Image<std::uint8_t>& out);

// out = the right image brought onto the left's rows: shift_rows without a roll, else turned
// back by it (cv::warpAffine, linear, borders repeated). `out` is resized to `right`.
void align_rows(ImageView<const std::uint8_t> right, const RowAlignment& alignment,
                Image<std::uint8_t>& out);

}  // namespace dco::stereo
