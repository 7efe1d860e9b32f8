#pragma once

#include "dco/core/calibration.hpp"
#include "dco/core/image.hpp"

namespace dco {

// Metric depth (metres) of every pixel of a disparity map given in pixels of the rectified
// geometry: Z = f * baseline / (d + doffs). Unknown disparities (non-finite or <= -doffs) give
// +inf. `depth` must have the disparity's size.
void disparity_to_depth(ImageView<const float> disparity, const RectifiedGeometry& geometry,
                        ImageView<float> depth);

}  // namespace dco
