#include "dco/tools/sgbm_wls.hpp"

#include <chrono>
#include <limits>

#include <fmt/format.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/ximgproc/disparity_filter.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/error.hpp"

namespace dco::tools {
namespace {

constexpr int kBlockSize = 5;
constexpr double kWlsLambda = 8000.0;
constexpr double kWlsSigmaColor = 1.5;
// OpenCV matchers report disparities in 1/16 px (StereoMatcher::DISP_SHIFT = 4).
constexpr float kFixedPointScale = 1.0f / 16.0f;

// At most 2048: OpenCV keeps disparities as 16-bit sixteenths of a pixel.
constexpr long kMaxDisparityCount = 2048;

// SGBM searches a multiple of 16 disparities.
long disparity_count(int max_disp) {
  return (static_cast<long>(max_disp) + 15) / 16 * 16;
}

void check_inputs(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                  int max_disp) {
  if (left.empty() || right.empty()) throw Error("sgbm-wls: empty input image");
  if (!left.same_size(right))
    throw Error(fmt::format("sgbm-wls: left is {}x{} but right is {}x{}", left.width, left.height,
                            right.width, right.height));
  if (left.channels != right.channels || (left.channels != 1 && left.channels != 3))
    throw Error(fmt::format("sgbm-wls: needs 1 or 3 channels on both sides (got {} and {})",
                            left.channels, right.channels));
  if (max_disp <= 0)
    throw Error(fmt::format("sgbm-wls: max_disp must be positive (got {})", max_disp));
  // A larger count wraps disparities from 2048 px on negative, which reads as "no prediction".
  if (disparity_count(max_disp) > kMaxDisparityCount)
    throw Error(
        fmt::format("sgbm-wls: {} disparities (max_disp {}) are more than OpenCV's "
                    "StereoSGBM holds ({})",
                    disparity_count(max_disp), max_disp, kMaxDisparityCount));
  // OpenCV's SGBM aborts the process (an exception out of a destructor) on images no wider than
  // its disparity count.
  if (static_cast<long>(left.width) <= disparity_count(max_disp))
    throw Error(
        fmt::format("sgbm-wls: images {} px wide are too narrow for {} disparities (max_disp "
                    "{} rounded up to 16)",
                    left.width, disparity_count(max_disp), max_disp));
}

cv::Ptr<cv::StereoSGBM> make_left_matcher(int max_disp, int channels) {
  const int num_disparities = static_cast<int>(disparity_count(max_disp));
  const int area = kBlockSize * kBlockSize;
  return cv::StereoSGBM::create(/*minDisparity=*/0, num_disparities, kBlockSize,
                                /*P1=*/8 * channels * area, /*P2=*/32 * channels * area,
                                /*disp12MaxDiff=*/1, /*preFilterCap=*/63, /*uniquenessRatio=*/10,
                                /*speckleWindowSize=*/100, /*speckleRange=*/2,
                                cv::StereoSGBM::MODE_SGBM_3WAY);
}

}  // namespace

BaselineResult run_sgbm_wls(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                            int max_disp) {
  check_inputs(left, right, max_disp);
  const cv::Mat left_mat = as_mat(left);
  const cv::Mat right_mat = as_mat(right);

  const auto start = std::chrono::steady_clock::now();
  const cv::Ptr<cv::StereoSGBM> left_matcher = make_left_matcher(max_disp, left.channels);
  const cv::Ptr<cv::ximgproc::DisparityWLSFilter> wls =
      cv::ximgproc::createDisparityWLSFilter(left_matcher);
  const cv::Ptr<cv::StereoMatcher> right_matcher = cv::ximgproc::createRightMatcher(left_matcher);
  wls->setLambda(kWlsLambda);
  wls->setSigmaColor(kWlsSigmaColor);

  cv::Mat left_disp, right_disp, filtered;
  left_matcher->compute(left_mat, right_mat, left_disp);
  right_matcher->compute(right_mat, left_mat, right_disp);
  wls->filter(left_disp, left_mat, filtered, right_disp, cv::Rect(), right_mat);

  BaselineResult result;
  result.disparity.resize(left.width, left.height);
  for (int y = 0; y < left.height; ++y) {
    const auto* in = filtered.ptr<std::int16_t>(y);
    float* out = result.disparity.row(y);
    // Outside the matcher's valid region the filter writes (minDisparity - 1) * 16 < 0.
    for (int x = 0; x < left.width; ++x)
      out[x] = in[x] > 0 ? in[x] * kFixedPointScale : std::numeric_limits<float>::infinity();
  }
  result.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace dco::tools
