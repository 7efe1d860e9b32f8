#include "overlays.hpp"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/image_io.hpp"

namespace dco::tools {
namespace {

cv::Mat to_bgr(ImageView<const std::uint8_t> image) {
  cv::Mat bgr;
  if (image.channels == 3)
    bgr = as_mat(image).clone();
  else
    cv::cvtColor(as_mat(image), bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

}  // namespace

void write_disparity_colour(const std::filesystem::path& path, ImageView<const float> disparity,
                            float max_disparity) {
  cv::Mat scaled(disparity.height, disparity.width, CV_8U);
  cv::Mat unknown(disparity.height, disparity.width, CV_8U, cv::Scalar(0));
  for (int y = 0; y < disparity.height; ++y)
    for (int x = 0; x < disparity.width; ++x) {
      const float d = disparity.row(y)[x];
      const bool known = std::isfinite(d) && d > 0;
      scaled.at<std::uint8_t>(y, x) =
          known ? static_cast<std::uint8_t>(std::lround(std::fmin(d / max_disparity, 1.0f) * 255))
                : 0;
      unknown.at<std::uint8_t>(y, x) = known ? 0 : 255;
    }
  cv::Mat colour;
  cv::applyColorMap(scaled, colour, cv::COLORMAP_TURBO);
  colour.setTo(cv::Scalar(0, 0, 0), unknown);
  write_image_file(path, colour, "overlay");
}

void write_contour_overlay(const std::filesystem::path& path, ImageView<const std::uint8_t> image,
                           ImageView<const std::uint8_t> contours) {
  cv::Mat bgr = to_bgr(image);
  bgr.setTo(cv::Scalar(0, 0, 255), as_mat(contours) != 0);
  write_image_file(path, bgr, "overlay");
}

void write_occlusion_composite(const std::filesystem::path& path,
                               ImageView<const std::uint8_t> image,
                               ImageView<const float> disparity, float plane_disparity) {
  cv::Mat bgr = to_bgr(image);
  constexpr int kCell = 16;
  for (int y = 0; y < bgr.rows; ++y)
    for (int x = 0; x < bgr.cols; ++x) {
      const float d = disparity.row(y)[x];
      if (std::isfinite(d) && d >= plane_disparity) continue;  // a real object hides the plane
      const bool dark = ((x / kCell) + (y / kCell)) % 2 == 0;
      cv::Vec3b& p = bgr.at<cv::Vec3b>(y, x);
      const cv::Vec3b plane = dark ? cv::Vec3b(160, 60, 20) : cv::Vec3b(240, 160, 80);
      for (int c = 0; c < 3; ++c) p[c] = static_cast<std::uint8_t>((p[c] + 3 * plane[c]) / 4);
    }
  write_image_file(path, bgr, "overlay");
}

}  // namespace dco::tools
