// A turn about the image centre: OpenCV's warpAffine (linear, borders repeated) byte for byte,
// without its per-call buffers.
#include "dco/core/image_turn.hpp"

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "dco/core/cv_interop.hpp"
#include "support/allocation_counter.hpp"
#include "support/same_bytes.hpp"

namespace dco {
namespace {

Image<std::uint8_t> random_image(int w, int h, int channels, unsigned seed) {
  Image<std::uint8_t> img(w, h, channels);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> value(0, 255);
  for (int y = 0; y < h; ++y)
    for (int i = 0; i < w * channels; ++i)
      img.view().row(y)[i] = static_cast<std::uint8_t>(value(rng));
  return img;
}

Image<std::uint8_t> warp_affine(ImageView<const std::uint8_t> src, double radians, double down) {
  Image<std::uint8_t> out(src.width, src.height, src.channels);
  const double c = std::cos(radians), s = std::sin(radians);
  const double xc = 0.5 * (src.width - 1), yc = 0.5 * (src.height - 1);
  const cv::Matx23d to_src(c, -s, xc - c * xc + s * yc, s, c, yc - s * xc - c * yc + down);
  cv::Mat dst = as_mat(out.view());
  cv::warpAffine(as_mat(src), dst, to_src, dst.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                 cv::BORDER_REPLICATE);
  return out;
}

struct TurnCase {
  int width, height, channels;
  double degrees, down;
};

TEST(TurnAboutCentre, GivesWarpAffinesBytes) {
  // Small and odd sizes, both channel counts the pipeline turns and one it does not, rolls of a
  // cheap module's mount and far past it, offsets that take whole rows in from the borders.
  const TurnCase cases[] = {
      {1280, 720, 3, 0.2, 0.4}, {1280, 720, 1, -0.35, -1.25}, {641, 361, 3, 0.05, 0.0},
      {333, 97, 1, 5.0, 2.5},   {97, 333, 3, -12.0, -3.0},    {64, 48, 2, 30.0, 0.75},
      {2, 2, 1, 45.0, 0.5},     {1, 9, 3, 1.0, -0.3},         {9, 1, 1, -1.0, 0.3},
      {200, 100, 3, 0.0, 40.0}, {200, 100, 1, 0.0, -40.0},    {150, 150, 3, 180.0, 0.0},
  };
  unsigned seed = 1;
  for (const TurnCase& t : cases) {
    const Image<std::uint8_t> src = random_image(t.width, t.height, t.channels, seed++);
    const double radians = t.degrees * std::numbers::pi / 180.0;
    Image<std::uint8_t> out;
    turn_about_centre(src.cview(), radians, t.down, out);
    EXPECT_TRUE(testing::same_bytes(out, warp_affine(src.cview(), radians, t.down)))
        << t.width << "x" << t.height << "x" << t.channels << " turned " << t.degrees << " deg, "
        << t.down << " rows down";
  }
}

TEST(TurnAboutCentre, ReadsAViewWithPaddedRows) {
  const Image<std::uint8_t> big = random_image(300, 200, 3, 7);
  const ImageView<const std::uint8_t> part = big.cview().sub(13, 21, 250, 150);
  Image<std::uint8_t> out;
  turn_about_centre(part, 0.01, 0.6, out);
  EXPECT_TRUE(testing::same_bytes(out, warp_affine(part, 0.01, 0.6)));
}

TEST(TurnAboutCentre, AllocatesNothingIntoAnImageOfItsSize) {
  const Image<std::uint8_t> src = random_image(1280, 720, 3, 3);
  Image<std::uint8_t> out;
  turn_about_centre(src.cview(), 0.003, 0.4, out);
  testing::start_counting_allocations();
  for (int i = 0; i < 3; ++i) turn_about_centre(src.cview(), 0.003 * i, 0.4, out);
  const testing::AllocationCounts counts = testing::stop_counting_allocations();
  EXPECT_EQ(counts.total(), 0);
}

}  // namespace
}  // namespace dco
