#pragma once

// Shared by the occlusion and boundary metrics: which side of a virtual fronto-parallel plane
// each pixel of a disparity map is on.

#include <cstdint>

#include <opencv2/core.hpp>

#include "dco/core/image.hpp"
#include "dco/tools/metrics.hpp"

namespace dco::tools::detail {

enum Side : std::uint8_t { kBehind = 0, kFront = 1, kNoValue = 2 };

// kFront where disparity > plane, kBehind where it is not, kNoValue where the map has no value.
inline cv::Mat plane_sides(ImageView<const float> disparity, double plane) {
  cv::Mat sides(disparity.height, disparity.width, CV_8U);
  for (int y = 0; y < disparity.height; ++y) {
    const float* d = disparity.row(y);
    auto* s = sides.ptr<std::uint8_t>(y);
    for (int x = 0; x < disparity.width; ++x)
      s[x] = !is_valid_disparity(d[x]) ? kNoValue : (d[x] > plane ? kFront : kBehind);
  }
  return sides;
}

}  // namespace dco::tools::detail
