#include "dco/tools/sgbm_wls.hpp"

#include <cmath>
#include <cstdint>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/error.hpp"

namespace dco::tools {
namespace {

constexpr int kShift = 8;

// A random texture and the same texture seen kShift px further left: the left image's true
// disparity is kShift everywhere (right(x - d) = left(x)).
struct ShiftedPair {
  Image<std::uint8_t> left, right;
};

ShiftedPair shifted_texture(int width, int height, int channels) {
  cv::Mat texture(height, width + kShift, CV_8UC(channels));
  cv::RNG rng(1234);
  rng.fill(texture, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(texture, texture, {3, 3}, 0.7);  // camera-like, so subpixel fits are smooth
  ShiftedPair pair{Image<std::uint8_t>(width, height, channels),
                   Image<std::uint8_t>(width, height, channels)};
  pair.left.copy_from(as_view<std::uint8_t>(texture(cv::Rect(0, 0, width, height))));
  pair.right.copy_from(as_view<std::uint8_t>(texture(cv::Rect(kShift, 0, width, height))));
  return pair;
}

// Share of interior pixels (away from the borders the matcher cannot see) within 1 px of kShift.
double interior_accuracy(const Image<float>& disparity, int max_disp) {
  int total = 0, good = 0;
  for (int y = 8; y < disparity.height() - 8; ++y)
    for (int x = max_disp + 8; x < disparity.width() - 8; ++x) {
      ++total;
      good += std::abs(disparity.at(x, y) - kShift) <= 1.0f;
    }
  return static_cast<double>(good) / total;
}

void expect_only_positive_or_inf(const Image<float>& disparity) {
  for (int y = 0; y < disparity.height(); ++y)
    for (int x = 0; x < disparity.width(); ++x) {
      const float d = disparity.at(x, y);
      ASSERT_TRUE(d == INFINITY || (std::isfinite(d) && d > 0)) << x << "," << y << ": " << d;
    }
}

TEST(SgbmWls, RecoversAConstantShiftOnGrayTexture) {
  const ShiftedPair pair = shifted_texture(160, 120, 1);
  const BaselineResult r = run_sgbm_wls(pair.left.view(), pair.right.view(), 16);
  ASSERT_EQ(r.disparity.width(), 160);
  ASSERT_EQ(r.disparity.height(), 120);
  EXPECT_GT(interior_accuracy(r.disparity, 16), 0.9);
  EXPECT_GT(r.time_ms, 0);
  expect_only_positive_or_inf(r.disparity);
}

TEST(SgbmWls, RecoversAConstantShiftOnColourTextureWithOddRange) {
  const ShiftedPair pair = shifted_texture(200, 100, 3);
  const BaselineResult r = run_sgbm_wls(pair.left.view(), pair.right.view(), 21);  // -> 32
  EXPECT_GT(interior_accuracy(r.disparity, 32), 0.9);
  expect_only_positive_or_inf(r.disparity);
}

TEST(SgbmWls, RejectsBadInput) {
  const ShiftedPair pair = shifted_texture(64, 48, 1);
  Image<std::uint8_t> smaller(60, 48);
  smaller.fill(0);
  Image<std::uint8_t> two_channels(64, 48, 2);
  two_channels.fill(0);
  EXPECT_THROW(run_sgbm_wls(pair.left.view(), smaller.view(), 16), Error);
  EXPECT_THROW(run_sgbm_wls(two_channels.view(), two_channels.view(), 16), Error);
  EXPECT_THROW(run_sgbm_wls(pair.left.view(), pair.right.view(), 0), Error);
  EXPECT_THROW(run_sgbm_wls(ImageView<const std::uint8_t>(), pair.right.view(), 16), Error);
  // OpenCV aborts the process on images no wider than the disparity count (a multiple of 16).
  for (const int too_many : {49, 64, 80, 200})
    EXPECT_THROW(run_sgbm_wls(pair.left.view(), pair.right.view(), too_many), Error) << too_many;
  EXPECT_NO_THROW(run_sgbm_wls(pair.left.view(), pair.right.view(), 48));
  // OpenCV holds disparities as 16-bit sixteenths of a pixel: from 2048 px on they would wrap
  // negative and read as "no prediction", so more than 2048 disparities are refused.
  const ShiftedPair wide = shifted_texture(2200, 8, 1);
  try {
    run_sgbm_wls(wide.left.view(), wide.right.view(), 2049);
    ADD_FAILURE() << "2064 disparities accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("more than OpenCV's StereoSGBM holds (2048)"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace dco::tools
