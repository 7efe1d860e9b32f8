#include "dco/pipeline/stereo/image_ops.hpp"

#include <cmath>
#include <cstdint>
#include <random>
#include <utility>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "dco/core/cv_interop.hpp"
#include "pipeline_test_support.hpp"

namespace dco::stereo {
namespace {

Image<std::uint8_t> half_of(const Image<std::uint8_t>& in) {
  Image<std::uint8_t> out(in.width() / 2, in.height() / 2, in.channels());
  downsample_half(in.view(), out.view());
  return out;
}

TEST(DownsampleHalf, KnownBlocksRoundHalfUp) {
  Image<std::uint8_t> in(10, 2);
  const int top[10] = {0, 1, 1, 1, 255, 255, 0, 0, 0, 0};
  const int bottom[10] = {2, 3, 1, 2, 255, 255, 0, 1, 1, 1};
  for (int x = 0; x < 10; ++x) {
    in.at(x, 0) = static_cast<std::uint8_t>(top[x]);
    in.at(x, 1) = static_cast<std::uint8_t>(bottom[x]);
  }
  const auto out = half_of(in);
  ASSERT_EQ(out.width(), 5);
  ASSERT_EQ(out.height(), 1);
  EXPECT_EQ(out.at(0, 0), 2);    // 1.5 -> 2
  EXPECT_EQ(out.at(1, 0), 1);    // 1.25 -> 1
  EXPECT_EQ(out.at(2, 0), 255);  // no overflow
  EXPECT_EQ(out.at(3, 0), 0);    // 0.25 -> 0
  EXPECT_EQ(out.at(4, 0), 1);    // 0.5 -> 1
}

TEST(DownsampleHalf, OddSizesDropTheLastColumnAndRow) {
  Image<std::uint8_t> in(5, 3);
  in.fill(255);  // the dropped column 4 and row 2 must not leak into the result
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x) in.at(x, y) = static_cast<std::uint8_t>(10 * (x / 2) + 4);
  const auto out = half_of(in);
  ASSERT_EQ(out.width(), 2);
  ASSERT_EQ(out.height(), 1);
  EXPECT_EQ(out.at(0, 0), 4);
  EXPECT_EQ(out.at(1, 0), 14);

  Image<std::uint8_t> tiny(1, 1);
  tiny.fill(9);
  const auto none = half_of(tiny);
  EXPECT_TRUE(none.empty());
}

TEST(DownsampleHalf, ThreeChannelsAreIndependent) {
  Image<std::uint8_t> in(2, 2, 3);
  const int px[4][3] = {{0, 100, 255}, {1, 100, 255}, {0, 101, 255}, {1, 101, 250}};
  for (int i = 0; i < 4; ++i)
    for (int c = 0; c < 3; ++c) in.at(i % 2, i / 2, c) = static_cast<std::uint8_t>(px[i][c]);
  const auto out = half_of(in);
  ASSERT_EQ(out.channels(), 3);
  EXPECT_EQ(out.at(0, 0, 0), 1);    // 0.5
  EXPECT_EQ(out.at(0, 0, 1), 101);  // 100.5
  EXPECT_EQ(out.at(0, 0, 2), 254);  // 253.75
}

TEST(DownsampleHalf, MatchesTheFormulaOnRandomImagesAndStridedViews) {
  std::mt19937 rng(31);
  for (int channels : {1, 3})
    for (auto [w, h] : {std::pair{2, 2}, {7, 9}, {64, 33}}) {
      const auto big = test::random_image<std::uint8_t>(rng, w + 3, h + 2, channels, 0, 255);
      const auto in = big.view().sub(1, 1, w, h);
      Image<std::uint8_t> out(w / 2, h / 2, channels);
      downsample_half(in, out.view());
      for (int y = 0; y < h / 2; ++y)
        for (int x = 0; x < w / 2; ++x)
          for (int c = 0; c < channels; ++c) {
            const int sum = in.at(2 * x, 2 * y, c) + in.at(2 * x + 1, 2 * y, c) +
                            in.at(2 * x, 2 * y + 1, c) + in.at(2 * x + 1, 2 * y + 1, c);
            ASSERT_EQ(out.at(x, y, c), static_cast<int>(std::floor(sum / 4.0 + 0.5)))
                << x << "," << y << "," << c;
          }
    }
}

TEST(DownsampleHalf, MatchesOpenCvAreaResize) {
  std::mt19937 rng(32);
  for (int channels : {1, 3}) {
    const auto in = test::random_image<std::uint8_t>(rng, 64, 40, channels, 0, 255);
    const auto out = half_of(in);
    cv::Mat expected;
    cv::resize(as_mat(in.view()), expected, cv::Size(32, 20), 0, 0, cv::INTER_AREA);
    cv::Mat got = as_mat(out.view());
    EXPECT_EQ(cv::norm(got, expected, cv::NORM_INF), 0.0) << channels << " channels";
  }
}

TEST(BgrToGray, PrimaryColoursUseBgrOrder) {
  Image<std::uint8_t> bgr(5, 1, 3);
  const int px[5][3] = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {255, 255, 255}, {0, 0, 0}};
  for (int x = 0; x < 5; ++x)
    for (int c = 0; c < 3; ++c) bgr.at(x, 0, c) = static_cast<std::uint8_t>(px[x][c]);
  Image<std::uint8_t> gray(5, 1);
  bgr_to_gray(bgr.view(), gray.view());
  EXPECT_EQ(gray.at(0, 0), 29);   // blue:  0.114 * 255
  EXPECT_EQ(gray.at(1, 0), 150);  // green: 0.587 * 255
  EXPECT_EQ(gray.at(2, 0), 76);   // red:   0.299 * 255
  EXPECT_EQ(gray.at(3, 0), 255);
  EXPECT_EQ(gray.at(4, 0), 0);
}

TEST(BgrToGray, MatchesTheFixedPointFormulaAndTheRealWeights) {
  std::mt19937 rng(33);
  const auto big = test::random_image<std::uint8_t>(rng, 50, 20, 3, 0, 255);
  const auto bgr = big.view().sub(3, 2, 41, 15);
  Image<std::uint8_t> gray(41, 15);
  bgr_to_gray(bgr, gray.view());
  for (int y = 0; y < 15; ++y)
    for (int x = 0; x < 41; ++x) {
      const int b = bgr.at(x, y, 0), g = bgr.at(x, y, 1), r = bgr.at(x, y, 2);
      ASSERT_EQ(gray.at(x, y), (b * 1868 + g * 9617 + r * 4899 + 8192) >> 14) << x << "," << y;
      ASSERT_NEAR(gray.at(x, y), 0.114 * b + 0.587 * g + 0.299 * r, 0.51) << x << "," << y;
    }
}

TEST(BgrToGray, WithinOneOfOpenCvCvtColor) {
  std::mt19937 rng(34);
  const auto bgr = test::random_image<std::uint8_t>(rng, 256, 64, 3, 0, 255);
  Image<std::uint8_t> gray(256, 64);
  bgr_to_gray(bgr.view(), gray.view());
  cv::Mat expected;
  cv::cvtColor(as_mat(bgr.view()), expected, cv::COLOR_BGR2GRAY);
  cv::Mat diff;
  cv::absdiff(as_mat(gray.view()), expected, diff);
  EXPECT_LE(cv::norm(diff, cv::NORM_INF), 1.0);
  EXPECT_LT(cv::countNonZero(diff), diff.rows * diff.cols / 100);
}

TEST(BgrToGray, BitExactWithOpenCvCvtColor) {
  std::mt19937 rng(35);
  const auto bgr = test::random_image<std::uint8_t>(rng, 256, 64, 3, 0, 255);
  Image<std::uint8_t> gray(256, 64);
  bgr_to_gray(bgr.view(), gray.view());
  cv::Mat expected;
  cv::cvtColor(as_mat(bgr.view()), expected, cv::COLOR_BGR2GRAY);
  EXPECT_EQ(cv::norm(as_mat(gray.view()), expected, cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace dco::stereo
