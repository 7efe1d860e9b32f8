#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/image.hpp"
#include "dco/pipeline/contour/gated_canny.hpp"
#include "dco/pipeline/contour/separable_filters.hpp"
#include "pipeline_test_support.hpp"

// The contour stage's own filters must agree with OpenCV's (replicated border), which they replace
// only to keep the per-frame path free of allocations.
namespace dco::contour {
namespace {

float max_abs_diff(ImageView<const float> a, const cv::Mat& b) {
  float worst = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x)
      worst = std::max(worst, std::fabs(a.at(x, y) - b.at<float>(y, x)));
  return worst;
}

TEST(ContourFilters, GaussianMatchesOpenCv) {
  std::mt19937 rng(7);
  for (const auto& [w, h] :
       {std::pair{97, 61}, std::pair{5, 3}, std::pair{1, 1}, std::pair{2, 9}}) {
    const Image<std::uint8_t> img = test::random_image<std::uint8_t>(rng, w, h, 1, 0, 255);
    Image<float> tmp(w, h), out(w, h);
    gaussian_blur_5x5(img.view(), tmp.view(), out.view());
    cv::Mat src, expected;
    as_mat(img.view()).convertTo(src, CV_32F);
    cv::GaussianBlur(src, expected, {5, 5}, 1.4, 1.4, cv::BORDER_REPLICATE);
    EXPECT_LT(max_abs_diff(out.view(), expected), 1e-3f) << w << "x" << h;
  }
}

TEST(ContourFilters, BoxMatchesOpenCv) {
  std::mt19937 rng(8);
  for (const int size : {1, 3, 9, 15})
    for (const auto& [w, h] : {std::pair{83, 47}, std::pair{4, 6}, std::pair{1, 1}}) {
      const Image<std::uint8_t> bytes = test::random_image<std::uint8_t>(rng, w, h, 1, 0, 255);
      Image<float> img(w, h), tmp(w, h), out(w, h);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) img.at(x, y) = bytes.at(x, y) / 255.0f;
      box_filter(img.view(), size, tmp.view(), out.view());
      cv::Mat expected;
      cv::boxFilter(as_mat(img.view()), expected, CV_32F, {size, size}, {-1, -1}, true,
                    cv::BORDER_REPLICATE);
      EXPECT_LT(max_abs_diff(out.view(), expected), 1e-5f) << size << " on " << w << "x" << h;
    }
}

TEST(ContourFilters, BoxKeepsZeroExactlyZero) {
  Image<float> img(40, 30), tmp(40, 30), out(40, 30);
  img.fill(0.0f);
  img.at(5, 5) = 1.0f;
  box_filter(img.view(), 9, tmp.view(), out.view());
  EXPECT_FLOAT_EQ(out.at(5, 5), 1.0f / 81.0f);
  EXPECT_EQ(out.at(20, 20), 0.0f);  // far from the impulse: exactly zero, no drift
}

TEST(ContourFilters, SobelMatchesOpenCvAndQuantisesDirections) {
  std::mt19937 rng(9);
  const int w = 64, h = 48;
  const Image<std::uint8_t> bytes = test::random_image<std::uint8_t>(rng, w, h, 1, 0, 255);
  Image<float> img(w, h), mag(w, h);
  Image<std::uint8_t> dir(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) img.at(x, y) = bytes.at(x, y);
  sobel_magnitude(img.view(), 1.0f, mag.view(), dir.view());
  cv::Mat gx, gy, expected;
  cv::Sobel(as_mat(img.view()), gx, CV_32F, 1, 0, 3, 1, 0, cv::BORDER_REPLICATE);
  cv::Sobel(as_mat(img.view()), gy, CV_32F, 0, 1, 3, 1, 0, cv::BORDER_REPLICATE);
  cv::magnitude(gx, gy, expected);
  EXPECT_LT(max_abs_diff(mag.view(), expected), 1e-2f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double angle =
          std::atan2(gy.at<float>(y, x), gx.at<float>(y, x)) * 180 / std::numbers::pi;
      const double a = std::fmod(angle + 360.0, 180.0);  // the axis, not the sign
      int expected_dir = kHorizontal;
      if (a > 22.5 && a < 67.5) expected_dir = kDiagonalDown;
      if (a >= 67.5 && a <= 112.5) expected_dir = kVertical;
      if (a > 112.5 && a < 157.5) expected_dir = kDiagonalUp;
      const bool on_border = std::fabs(std::fmod(a, 45.0) - 22.5) < 0.01;
      if (on_border) continue;
      EXPECT_EQ(dir.at(x, y), expected_dir) << x << "," << y << " " << a;
    }
}

// The normalising constant is the real maximum: a 3x3 pattern reaches it, none exceeds it.
TEST(ContourFilters, SobelNormIsTheLargestMagnitudeOf8BitInput) {
  float largest = 0;
  Image<float> img(3, 3), mag(3, 3);
  Image<std::uint8_t> dir(3, 3);
  for (int bits = 0; bits < 512; ++bits) {
    for (int i = 0; i < 9; ++i) img.at(i % 3, i / 3) = (bits >> i) & 1 ? 255.0f : 0.0f;
    sobel_magnitude(img.view(), 1.0f, mag.view(), dir.view());
    largest = std::max(largest, mag.at(1, 1));
  }
  EXPECT_NEAR(largest, kMaxSobelMagnitude8Bit, 1e-2f);
}

}  // namespace
}  // namespace dco::contour
