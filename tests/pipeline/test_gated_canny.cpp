#include "dco/pipeline/contour/gated_canny.hpp"

#include <bit>
#include <cstdint>
#include <queue>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/image.hpp"
#include "dco/kernels/canny_kernels.hpp"
#include "dco/kernels/contour_pixel.hpp"
#include "dco/pipeline/contour/separable_filters.hpp"
#include "support/same_bytes.hpp"

namespace dco::contour {
namespace {

// Blur, gradient and gated Canny as the extractor runs them.
Image<std::uint8_t> canny(const Image<std::uint8_t>& img, ImageView<const float> gate,
                          const CannyThresholds& t = {}) {
  const int w = img.width(), h = img.height();
  Image<float> tmp(w, h), blurred(w, h), mag(w, h);
  Image<std::uint8_t> dir(w, h), edges(w, h);
  gaussian_blur_5x5(img.view(), tmp.view(), blurred.view());
  sobel_magnitude(blurred.view(), kMaxSobelMagnitude8Bit, mag.view(), dir.view());
  CannyScratch scratch;
  gated_canny(mag.view(), dir.view(), gate, t, edges.view(), scratch);
  return edges;
}

constexpr int kW = 80, kH = 64;
constexpr int kX0 = 20, kY0 = 16, kSide = 40;  // the bright square covers [20, 60) x [16, 56)

Image<std::uint8_t> square_image() {
  Image<std::uint8_t> img(kW, kH);
  img.fill(30);
  for (int y = kY0; y < kY0 + kSide; ++y)
    for (int x = kX0; x < kX0 + kSide; ++x) img.at(x, y) = 200;
  return img;
}

int count_edges(const Image<std::uint8_t>& e, int x_begin = 0, int x_end = kW) {
  int n = 0;
  for (int y = 0; y < e.height(); ++y)
    for (int x = x_begin; x < x_end; ++x) n += e.at(x, y) == 255;
  return n;
}

// Pixels reachable from (x, y) through 4-connected non-edge pixels.
Image<std::uint8_t> flood_outside_edges(const Image<std::uint8_t>& e, int x, int y) {
  Image<std::uint8_t> seen(e.width(), e.height());
  seen.fill(0);
  std::queue<std::pair<int, int>> frontier;
  frontier.push({x, y});
  seen.at(x, y) = 1;
  while (!frontier.empty()) {
    const auto [px, py] = frontier.front();
    frontier.pop();
    const int nx[4] = {px - 1, px + 1, px, px};
    const int ny[4] = {py, py, py - 1, py + 1};
    for (int i = 0; i < 4; ++i) {
      if (nx[i] < 0 || ny[i] < 0 || nx[i] >= e.width() || ny[i] >= e.height()) continue;
      if (seen.at(nx[i], ny[i]) || e.at(nx[i], ny[i]) == 255) continue;
      seen.at(nx[i], ny[i]) = 1;
      frontier.push({nx[i], ny[i]});
    }
  }
  return seen;
}

TEST(IntensityGradients, AreTheBlurThenSobelOfTheWholeImageRowByRow) {
  // The rows made one at a time in a ring of three give the bytes of the whole blurred image
  // through sobel_magnitude, on any size (one to three rows, a column, odd widths), and a scratch
  // sized for a wider image first changes nothing.
  std::mt19937 rng(9);
  std::uniform_int_distribution<int> grey(0, 255);
  GradientScratch scratch;
  scratch.resize(300);
  for (const auto& [w, h] :
       {std::pair{97, 61}, std::pair{64, 3}, std::pair{33, 2}, std::pair{17, 1}, std::pair{1, 9},
        std::pair{1, 1}, std::pair{280, 40}}) {
    Image<std::uint8_t> img(w, h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) img.at(x, y) = static_cast<std::uint8_t>(grey(rng));
    Image<float> tmp(w, h), blurred(w, h), expected_mag(w, h);
    Image<std::uint8_t> expected_dir(w, h);
    gaussian_blur_5x5(img.view(), tmp.view(), blurred.view());
    sobel_magnitude(blurred.view(), kMaxSobelMagnitude8Bit, expected_mag.view(),
                    expected_dir.view());
    Image<float> mag;
    Image<std::uint8_t> dir;
    intensity_gradients(img.view(), scratch, mag, dir);
    ASSERT_EQ(mag.width(), w);
    ASSERT_EQ(mag.height(), h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        ASSERT_EQ(std::bit_cast<std::uint32_t>(mag.at(x, y)),
                  std::bit_cast<std::uint32_t>(expected_mag.at(x, y)))
            << w << "x" << h << " at " << x << "," << y;
        ASSERT_EQ(dir.at(x, y), expected_dir.at(x, y)) << w << "x" << h << " at " << x << "," << y;
      }
  }
}

TEST(GatedCanny, SquareGivesAClosedOnePixelContourOnItsBoundary) {
  const Image<std::uint8_t> e = canny(square_image(), {});
  // Every edge pixel lies on the boundary, give or take the half pixel between the two sides.
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      if (e.at(x, y) != 255) continue;
      const bool near_vertical =
          (x >= kX0 - 1 && x <= kX0) || (x >= kX0 + kSide - 1 && x <= kX0 + kSide);
      const bool near_horizontal =
          (y >= kY0 - 1 && y <= kY0) || (y >= kY0 + kSide - 1 && y <= kY0 + kSide);
      const bool inside_band = x >= kX0 - 1 && x <= kX0 + kSide && y >= kY0 - 1 && y <= kY0 + kSide;
      EXPECT_TRUE(inside_band && (near_vertical || near_horizontal)) << x << "," << y;
    }
  // One pixel thick: each row (column) through the square's middle crosses exactly two edges.
  for (int y = kY0 + 3; y < kY0 + kSide - 3; ++y) {
    int n = 0;
    for (int x = 0; x < kW; ++x) n += e.at(x, y) == 255;
    EXPECT_EQ(n, 2) << "row " << y;
  }
  for (int x = kX0 + 3; x < kX0 + kSide - 3; ++x) {
    int n = 0;
    for (int y = 0; y < kH; ++y) n += e.at(x, y) == 255;
    EXPECT_EQ(n, 2) << "column " << x;
  }
  // Closed: the inside cannot be reached from the outside without crossing an edge.
  const Image<std::uint8_t> outside = flood_outside_edges(e, 0, 0);
  EXPECT_EQ(outside.at(kX0 + kSide / 2, kY0 + kSide / 2), 0);
  // No trace of the texture-free background or interior.
  EXPECT_GT(count_edges(e), 4 * (kSide - 4));
  EXPECT_LT(count_edges(e), 4 * (kSide + 2));
}

TEST(GatedCanny, GateClosedOnTheLeftHalfKeepsOnlyRightHalfEdges) {
  // The gate has half the image resolution, as M_fuse does: column g covers image columns 2g, 2g+1.
  Image<float> gate(kW / 2, kH / 2);
  for (int y = 0; y < gate.height(); ++y)
    for (int x = 0; x < gate.width(); ++x) gate.at(x, y) = x < gate.width() / 2 ? 0.0f : 1.0f;
  const Image<std::uint8_t> open = canny(square_image(), {});
  const Image<std::uint8_t> e = canny(square_image(), gate.view());
  EXPECT_EQ(count_edges(e, 0, kW / 2), 0);
  EXPECT_GT(count_edges(e, kW / 2, kW), kSide);
  // Right of the gate border (plus one pixel of hysteresis reach) nothing changes.
  for (int y = 0; y < kH; ++y)
    for (int x = kW / 2 + 1; x < kW; ++x) EXPECT_EQ(e.at(x, y), open.at(x, y)) << x << "," << y;
}

// An odd width has an internal frame of (w - 1) / 2 cells; cell g still covers columns 2g and
// 2g + 1, as in the matcher's output, and the last column takes the last cell.
TEST(GatedCanny, AnOddWidthReadsTheGateOfItsOwnColumns) {
  for (const int w : {66, 65}) {
    Image<float> magnitude(w, 5);
    Image<std::uint8_t> direction(w, 5), edges(w, 5);
    for (int y = 0; y < 5; ++y)
      for (int x = 0; x < w; ++x) {
        magnitude.at(x, y) = x % 2 == 0 ? 1.0f : 0.5f;
        direction.at(x, y) = 0;
      }
    Image<float> gate(w / 2, 2);
    gate.fill(0.0f);
    for (int y = 0; y < 2; ++y) gate.at(10, y) = 1.0f;  // image columns 20 and 21
    CannyScratch scratch;
    gated_canny(magnitude.cview(), direction.cview(), gate.cview(), {0.9f, 0.1f, 0.5f},
                edges.view(), scratch);
    std::vector<int> columns;
    for (int x = 0; x < w; ++x)
      if (edges.at(x, 2)) columns.push_back(x);
    EXPECT_EQ(columns, std::vector<int>{20}) << w;
  }
  EXPECT_EQ(kernels::pixel::gate_sample(64, 65, 32), 31);
  EXPECT_EQ(kernels::pixel::gate_sample(63, 65, 32), 31);
  EXPECT_EQ(kernels::pixel::gate_sample(21, 65, 32), 10);
  EXPECT_EQ(kernels::pixel::gate_sample(7, 9, 9), 7);
  EXPECT_EQ(kernels::pixel::gate_sample(9, 10, 4), 3);  // no whole ratio: proportional
}

TEST(GatedCanny, GateBelowTDepthOnlyRejects) {
  Image<float> gate(kW, kH);
  gate.fill(0.0299f);
  EXPECT_EQ(count_edges(canny(square_image(), gate.view())), 0);
  gate.fill(0.03f);  // at T_depth: still a candidate
  EXPECT_EQ(count_edges(canny(square_image(), gate.view())),
            count_edges(canny(square_image(), {})));
}

// Magnitudes set by hand: thin horizontal ridges whose gradient points along y, so non-maximum
// suppression keeps every ridge pixel and only the thresholds decide.
struct Ridges {
  Image<float> mag{64, 40};
  Image<std::uint8_t> dir{64, 40};
  Ridges() {
    mag.fill(0.0f);
    dir.fill(kVertical);
  }
  Image<std::uint8_t> run(ImageView<const float> gate = {}) const {
    Image<std::uint8_t> edges(64, 40);
    CannyScratch scratch;
    gated_canny(mag.view(), dir.view(), gate, {0.06f, 0.03f, 0.03f}, edges.view(), scratch);
    return edges;
  }
};

TEST(GatedCanny, HysteresisFollowsWeakPixelsFromAStrongOneOnly) {
  Ridges r;
  for (int x = 5; x <= 10; ++x) r.mag.at(x, 10) = 0.1f;    // strong
  for (int x = 11; x <= 40; ++x) r.mag.at(x, 10) = 0.04f;  // weak, touching the strong run
  for (int x = 41; x <= 50; ++x) r.mag.at(x, 11) = 0.04f;  // weak, one row down: 8-connected
  for (int x = 5; x <= 40; ++x) r.mag.at(x, 25) = 0.04f;   // weak, alone
  r.mag.at(20, 33) = 0.02f;                                // below T_low, next to a strong pixel
  r.mag.at(21, 33) = 0.5f;
  const Image<std::uint8_t> e = r.run();
  for (int x = 5; x <= 40; ++x) EXPECT_EQ(e.at(x, 10), 255) << x;
  for (int x = 41; x <= 50; ++x) EXPECT_EQ(e.at(x, 11), 255) << x;
  for (int x = 5; x <= 40; ++x) EXPECT_EQ(e.at(x, 25), 0) << x;
  EXPECT_EQ(e.at(20, 33), 0);
  EXPECT_EQ(e.at(21, 33), 255);
  EXPECT_EQ(count_edges(e, 0, 64), 36 + 10 + 1);
}

TEST(GatedCanny, GatedPixelsDoNotBridgeHysteresis) {
  Ridges r;
  for (int x = 5; x <= 10; ++x) r.mag.at(x, 10) = 0.1f;
  for (int x = 11; x <= 40; ++x) r.mag.at(x, 10) = 0.04f;
  Image<float> gate(64, 40);
  gate.fill(1.0f);
  gate.at(20, 10) = 0.0f;  // one gated pixel cuts the weak run
  const Image<std::uint8_t> e = r.run(gate.view());
  for (int x = 5; x <= 19; ++x) EXPECT_EQ(e.at(x, 10), 255) << x;
  for (int x = 20; x <= 40; ++x) EXPECT_EQ(e.at(x, 10), 0) << x;
}

TEST(GatedCanny, ThinsABlurredRampToOnePixel) {
  // A soft vertical step: intensity rises over ~10 px, so the raw gradient is wide.
  cv::Mat ramp(48, 96, CV_8U);
  for (int x = 0; x < 96; ++x) ramp.col(x).setTo(x < 48 ? 40 : 220);
  cv::GaussianBlur(ramp, ramp, {0, 0}, 3.0, 3.0, cv::BORDER_REPLICATE);
  Image<std::uint8_t> img(96, 48);
  img.copy_from(as_view<std::uint8_t>(static_cast<const cv::Mat&>(ramp)));
  const Image<std::uint8_t> e = canny(img, {});
  for (int y = 1; y < 47; ++y) {
    int n = 0, where = -1;
    for (int x = 0; x < 96; ++x)
      if (e.at(x, y) == 255) ++n, where = x;
    EXPECT_EQ(n, 1) << "row " << y;
    EXPECT_TRUE(where == 47 || where == 48) << "row " << y << " edge at " << where;
  }
}

TEST(GatedCanny, TinyImagesHaveNoEdges) {
  for (const auto& [w, h] : {std::pair{1, 1}, std::pair{2, 5}, std::pair{5, 2}}) {
    Image<float> mag(w, h);
    Image<std::uint8_t> dir(w, h), edges(w, h);
    mag.fill(1.0f);
    dir.fill(kHorizontal);
    CannyScratch scratch;
    gated_canny(mag.view(), dir.view(), {}, {}, edges.view(), scratch);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) EXPECT_EQ(edges.at(x, y), 0);
  }
}

// A frame's classes made before its gate, then gated, are gated_canny's bytes: with no gate, a
// gate of the image's size, of half its size (the contour stage's) and of another size, on a
// textured image with an outline; intensity_gradients_and_classes makes the classes of its own
// gradients in the same pass, on every size (one to three rows or columns have no interior).
TEST(GatedCanny, ClassesMadeBeforeTheGateGiveTheSameEdges) {
  std::mt19937 rng(12);
  std::uniform_int_distribution<int> grey(0, 60);
  std::uniform_real_distribution<float> level(0.0f, 0.06f);
  GradientScratch scratch;
  CannyScratch canny_scratch;
  const CannyThresholds t;
  for (const auto& [w, h] : {std::pair{97, 61}, std::pair{160, 90}, std::pair{3, 3},
                             std::pair{64, 2}, std::pair{2, 40}, std::pair{1, 1}}) {
    Image<std::uint8_t> img(w, h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        img.at(x, y) = static_cast<std::uint8_t>(grey(rng) + (x > w / 3 && y > h / 4 ? 150 : 0));
    Image<float> mag, own_mag;
    Image<std::uint8_t> dir, own_dir, own_classes;
    intensity_gradients(img.view(), scratch, mag, dir);
    Image<std::uint8_t> classes(w, h);
    classes.fill(9);
    canny_classes(mag.view(), dir.view(), t, classes.view());
    intensity_gradients_and_classes(img.view(), t, scratch, own_mag, own_dir, own_classes);
    ASSERT_TRUE(dco::testing::same_bytes(own_mag, mag)) << w << "x" << h;
    ASSERT_TRUE(dco::testing::same_bytes(own_dir, dir)) << w << "x" << h;
    ASSERT_TRUE(dco::testing::same_bytes(own_classes, classes)) << w << "x" << h;
    int kept = 0;
    for (const auto& [gw, gh] :
         {std::pair{0, 0}, std::pair{w, h}, std::pair{(w + 1) / 2, (h + 1) / 2},
          std::pair{std::max(1, w / 3), std::max(1, h / 5)}}) {
      Image<float> gate(gw, gh);
      for (int y = 0; y < gh; ++y)
        for (int x = 0; x < gw; ++x) gate.at(x, y) = level(rng);
      Image<std::uint8_t> expected(w, h), actual(w, h);
      expected.fill(7);  // neither call may leave a pixel unwritten
      actual.fill(9);
      gated_canny(mag.view(), dir.view(), gate.view(), t, expected.view(), canny_scratch);
      gated_canny_classified(classes.view(), gate.view(), t, actual.view(), canny_scratch);
      ASSERT_TRUE(dco::testing::same_bytes(actual, expected))
          << w << "x" << h << " gate " << gw << "x" << gh;
      kept += count_edges(expected, 0, w);
    }
    if (w > 50 && h > 50) {
      EXPECT_GT(kept, 0) << w << "x" << h;  // not trivially equal
    }
  }
}

// The hysteresis step against a plain breadth-first flood on random classified maps: weak pixels
// in every position of the eight-byte words the scan skips by, and in the row tails; maps mostly
// weak (long chains) and mostly strong (as real frames are: few weak pixels to link).
TEST(GatedCanny, HysteresisEqualsAFloodFromEveryStrongPixel) {
  std::mt19937 rng(4);
  for (const auto& [strong, weak] : {std::pair{3u, 42u}, std::pair{30u, 6u}})
    for (const int w : {3, 9, 17, 64, 71}) {
      const int h = 13;
      Image<std::uint8_t> map(w, h);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const bool border = x == 0 || y == 0 || x == w - 1 || y == h - 1;
          const unsigned pick = rng() % 100;
          map.at(x, y) = border                 ? kernels::kCannyNone
                         : pick < strong        ? kernels::kCannyStrong
                         : pick < strong + weak ? kernels::kCannyWeak
                                                : kernels::kCannyNone;
        }
      Image<std::uint8_t> expected(w, h);
      expected.fill(0);
      std::queue<std::pair<int, int>> frontier;
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          if (map.at(x, y) == kernels::kCannyStrong) {
            expected.at(x, y) = kernels::kCannyStrong;
            frontier.emplace(x, y);
          }
      while (!frontier.empty()) {
        const auto [x, y] = frontier.front();
        frontier.pop();
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int nx = x + dx, ny = y + dy;
            if (map.at(nx, ny) == kernels::kCannyWeak && expected.at(nx, ny) == 0) {
              expected.at(nx, ny) = kernels::kCannyStrong;
              frontier.emplace(nx, ny);
            }
          }
      }
      CannyScratch scratch;
      canny_hysteresis(map.view(), scratch);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          ASSERT_EQ(map.at(x, y), expected.at(x, y))
              << "strong " << strong << " % width " << w << " at " << x << "," << y;
    }
}

}  // namespace
}  // namespace dco::contour
