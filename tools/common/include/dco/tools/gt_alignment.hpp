#pragma once

#include <cstdint>

#include "dco/core/image.hpp"

// How well a scene's ground truth lines up with its own images. A stereo pair whose GT was made
// at another size or crop can be off its images by a constant: every matcher then looks worse
// by the same offset. The check needs no prediction, only the images and the GT.
namespace dco::tools {

struct GtAlignment {
  double offset_px = 0;        // the δ of the least photometric error (a multiple of step_px)
  double error_at_zero = 0;    // mean |L(x) − R(x − gt)| over the compared pixels, grey levels
  double error_at_offset = 0;  // the same at x − (gt + δ)
  std::int64_t pixels = 0;     // pixels compared (the same set for every δ)
};

// Samples the right image (linear interpolation along the row) at x − (gt + δ) for δ from
// −range_px to +range_px in steps of step_px and returns the δ where the mean absolute grey
// difference to the left image is least. Compared are the GT pixels (finite, > 0) with a
// horizontal grey step of at least 16 levels between their two row neighbours, whose samples
// stay inside the right image for every δ: on flat pixels a wrong disparity costs nothing.
// `left` and `right` are 1-channel 8-bit images of the GT's size. Throws dco::Error on other
// sizes or channel counts, a bad range or step, and when no pixel can be compared.
GtAlignment photometric_gt_alignment(ImageView<const std::uint8_t> left,
                                     ImageView<const std::uint8_t> right, ImageView<const float> gt,
                                     double range_px = 2.0, double step_px = 0.05);

// `gt` with `offset_px` added to every usable disparity; unknown pixels stay unknown, and so
// does a disparity the offset takes to 0 or below.
Image<float> shifted_ground_truth(ImageView<const float> gt, double offset_px);

}  // namespace dco::tools
