#pragma once

// Shared by the occlusion and boundary metrics and the error maps: which side of a virtual
// fronto-parallel plane each pixel of a disparity map is on, and the band around the boundary.

#include <cstdint>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

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

// Pixels within Chebyshev distance kOcclusionBandRadius of a pair of 4-neighbours for which
// `marks(x0, y0, x1, y1)` holds (both pixels of a marked pair are marked).
template <class Marks>
cv::Mat band_around(int width, int height, const Marks& marks) {
  cv::Mat marked = cv::Mat::zeros(height, width, CV_8U);
  for (int y = 0; y < height; ++y) {
    auto* m = marked.ptr<std::uint8_t>(y);
    auto* m_below = y + 1 < height ? marked.ptr<std::uint8_t>(y + 1) : nullptr;
    for (int x = 0; x < width; ++x) {
      if (x + 1 < width && marks(x, y, x + 1, y)) m[x] = m[x + 1] = 1;
      if (m_below && marks(x, y, x, y + 1)) m[x] = m_below[x] = 1;
    }
  }
  const int size = 2 * kOcclusionBandRadius + 1;
  cv::Mat band;
  cv::dilate(marked, band, cv::getStructuringElement(cv::MORPH_RECT, {size, size}));
  return band;
}

// Around the GT occlusion boundary: pairs whose GT sides differ (pixels without GT neither make
// nor break a boundary).
inline cv::Mat occlusion_band(const cv::Mat& sides) {
  return band_around(sides.cols, sides.rows, [&sides](int x0, int y0, int x1, int y1) {
    const std::uint8_t a = sides.at<std::uint8_t>(y0, x0), b = sides.at<std::uint8_t>(y1, x1);
    return a != kNoValue && b != kNoValue && a != b;
  });
}

}  // namespace dco::tools::detail
