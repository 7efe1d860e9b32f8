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
  for (int y = 0; y < slice.height; ++y) update_slice_row(slice.row(y), y, d);
}

void WinnerTakesAll::update_slice_row(const std::uint32_t* costs, int y, int d) {
  const int w = best_.width();
  narrowed_.resize(static_cast<std::size_t>(w));
  assert(std::all_of(costs, costs + w, [](std::uint32_t c) { return c < kNoCost; }));
  std::copy(costs, costs + w, narrowed_.begin());
  update_row(narrowed_.data(), 0, 1, y, d);
}

void WinnerTakesAll::update_row(const std::uint16_t* costs, std::ptrdiff_t stride, int count, int y,
                                int d) {
  static_assert(kNoCost == kernels::kNoCost);
  const int w = best_.width();
  for (int k = 0; k < count; ++k)
    assert(std::all_of(costs + k * stride, costs + k * stride + w,
                       [](std::uint16_t c) { return c < kNoCost; }));
  const kernels::WtaRow row{best_.row(y),       second_.row(y),    below_.row(y),  above_.row(y),
                            prev1_.row(y),      prev2_.row(y),     runmin_.row(y), disp_.row(y),
                            best_right_.row(y), disp_right_.row(y)};
  kernels::wta_update_row(costs, stride, count, w, d, row);
}

void WinnerTakesAll::skip_row(int y, int d, int count) {
  const kernels::WtaRow row{best_.row(y),       second_.row(y),    below_.row(y),  above_.row(y),
                            prev1_.row(y),      prev2_.row(y),     runmin_.row(y), disp_.row(y),
                            best_right_.row(y), disp_right_.row(y)};
  kernels::wta_skip_row(count, best_.width(), d, row);
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
                      int max_diff, std::vector<std::int32_t>& scratch) {
  assert(right.same_size(left));
  if (scratch.size() < static_cast<std::size_t>(left.width))
    scratch.resize(static_cast<std::size_t>(left.width));
  for (int y = 0; y < left.height; ++y)
    kernels::left_right_check_row(left.row(y), right.row(y), left.width, max_diff, scratch.data());
}

void uniqueness_check(ImageView<std::int16_t> disparity, ImageView<const std::uint16_t> best,
                      ImageView<const std::uint16_t> second, double ratio) {
  const double keep = 1.0 - ratio;  // kept when best <= keep * second
  for (int y = 0; y < disparity.height; ++y) {
    std::int16_t* d = disparity.row(y);
    const std::uint16_t* b = best.row(y);
    const std::uint16_t* s = second.row(y);
    // Branch-free, so the compiler vectorises it; an invalid pixel stays invalid either way.
    for (int x = 0; x < disparity.width; ++x)
      d[x] = kernels::pixel::unique_enough(b[x], s[x], keep) ? d[x] : kInvalidDisparity;
  }
}

void discontinuity_check(ImageView<std::int16_t> disparity, int max_jump,
                         Image<std::int16_t>& scratch) {
  assert(max_jump >= -1);
  const int w = disparity.width;
  const int h = disparity.height;
  // Row y of scratch: the largest value among the 8-neighbourhood (and the pixel) of each pixel
  // of row y before the check. Unreliable neighbours (-1) never exceed a reliable value by more
  // than max_jump >= -1, so the largest one decides kernels::pixel::behind_jump.
  scratch.resize(w, 3);
  std::int16_t* column_max = scratch.row(0);
  std::int16_t* previous = scratch.row(1);  // row y - 1 before the check
  std::int16_t* current = scratch.row(2);   // row y before the check
  std::copy(disparity.row(0), disparity.row(0) + w, current);
  for (int y = 0; y < h; ++y) {
    std::int16_t* out = disparity.row(y);
    const std::int16_t* above = y > 0 ? previous : current;
    const std::int16_t* below = y + 1 < h ? disparity.row(y + 1) : current;  // not yet checked
    for (int x = 0; x < w; ++x) column_max[x] = std::max(std::max(above[x], current[x]), below[x]);
    std::swap(previous, current);
    std::copy(below, below + w, current);  // row y + 1 before the check (unused past the end)
    const auto check = [&](int x, int nearest) {
      out[x] =
          out[x] != kInvalidDisparity && nearest - out[x] > max_jump ? kInvalidDisparity : out[x];
    };
    check(0, std::max(column_max[0], column_max[std::min(1, w - 1)]));
    for (int x = 1; x < w - 1; ++x)
      check(x, std::max(std::max(column_max[x - 1], column_max[x]), column_max[x + 1]));
    if (w > 1) check(w - 1, std::max(column_max[w - 2], column_max[w - 1]));
  }
}

}  // namespace dco::stereo
