#include "dco/pipeline/stereo/disparity_selection.hpp"

#include <algorithm>
#include <cassert>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/mat.hpp>

#include "dco/kernels/stereo_kernels.hpp"
#include "dco/kernels/stereo_pixel.hpp"

namespace dco::stereo {

void WinnerTakesAll::reset(int width, int height) {
  for (Image<std::uint16_t>* img :
       {&best_, &second_, &below_, &above_, &prev1_, &prev2_, &runmin_}) {
    img->resize(width, height);
    img->fill(kNoCost);
  }
  best_right_.resize(width, height);
  best_right_.fill(kNoCost);
  disp_.resize(width, height);
  disp_.fill(kInvalidDisparity);
  disp_right_.resize(width, height);
  disp_right_.fill(kInvalidDisparity);
}

void WinnerTakesAll::update(ImageView<const std::uint32_t> slice, int d) {
  for (int y = 0; y < slice.height; ++y) update_row(slice.row(y), 0, 1, y, d);
}

void WinnerTakesAll::update_row(const std::uint32_t* costs, std::ptrdiff_t stride, int count, int y,
                                int d) {
  static_assert(kNoCost == kernels::kNoCost);
  const int w = best_.width();
  for (int k = 0; k < count; ++k)
    assert(std::all_of(costs + k * stride, costs + k * stride + w,
                       [](std::uint32_t c) { return c < kNoCost; }));
  const kernels::WtaRow row{best_.row(y),       second_.row(y),    below_.row(y),  above_.row(y),
                            prev1_.row(y),      prev2_.row(y),     runmin_.row(y), disp_.row(y),
                            best_right_.row(y), disp_right_.row(y)};
  kernels::wta_update_row(costs, stride, count, w, d, row);
}

struct SpeckleFilter::Buffer {
  cv::Mat mat;
};
SpeckleFilter::SpeckleFilter() : buffer_(std::make_unique<Buffer>()) {}
SpeckleFilter::~SpeckleFilter() = default;
SpeckleFilter::SpeckleFilter(SpeckleFilter&&) noexcept = default;
SpeckleFilter& SpeckleFilter::operator=(SpeckleFilter&&) noexcept = default;

void SpeckleFilter::apply(ImageView<std::int16_t> disparity, int max_size, int max_diff) {
  cv::Mat map(disparity.height, disparity.width, CV_16SC1, disparity.data,
              static_cast<std::size_t>(disparity.stride) * sizeof(std::int16_t));
  cv::filterSpeckles(map, kInvalidDisparity, max_size, max_diff, buffer_->mat);
}

void left_right_check(ImageView<std::int16_t> left, ImageView<const std::int16_t> right,
                      int max_diff) {
  for (int y = 0; y < left.height; ++y) {
    std::int16_t* l = left.row(y);
    const std::int16_t* r = right.row(y);
    for (int x = 0; x < left.width; ++x)
      if (l[x] != kInvalidDisparity && !kernels::pixel::left_right_agree(x, l[x], r, max_diff))
        l[x] = kInvalidDisparity;
  }
}

void uniqueness_check(ImageView<std::int16_t> disparity, ImageView<const std::uint16_t> best,
                      ImageView<const std::uint16_t> second, double ratio) {
  const double keep = 1.0 - ratio;  // kept when best <= keep * second
  for (int y = 0; y < disparity.height; ++y) {
    std::int16_t* d = disparity.row(y);
    const std::uint16_t* b = best.row(y);
    const std::uint16_t* s = second.row(y);
    for (int x = 0; x < disparity.width; ++x)
      if (d[x] != kInvalidDisparity && !kernels::pixel::unique_enough(b[x], s[x], keep))
        d[x] = kInvalidDisparity;
  }
}

void discontinuity_check(ImageView<std::int16_t> disparity, int max_jump,
                         Image<std::int16_t>& scratch) {
  const int w = disparity.width;
  const int h = disparity.height;
  scratch.resize(w, h);
  scratch.copy_from(disparity);
  const auto at = [&scratch](int x, int y) { return int{scratch.at(x, y)}; };
  for (int y = 0; y < h; ++y) {
    std::int16_t* out = disparity.row(y);
    for (int x = 0; x < w; ++x)
      if (out[x] != kInvalidDisparity && kernels::pixel::behind_jump(at, x, y, w, h, max_jump))
        out[x] = kInvalidDisparity;
  }
}

}  // namespace dco::stereo
