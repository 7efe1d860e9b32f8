#include "dco/pipeline/stereo/disparity_selection.hpp"

#include <algorithm>
#include <cassert>
#include <cstdlib>

#include "dco/kernels/stereo_kernels.hpp"

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

void left_right_check(ImageView<std::int16_t> left, ImageView<const std::int16_t> right,
                      int max_diff) {
  for (int y = 0; y < left.height; ++y) {
    std::int16_t* l = left.row(y);
    const std::int16_t* r = right.row(y);
    for (int x = 0; x < left.width; ++x) {
      if (l[x] == kInvalidDisparity) continue;
      const int xr = x - l[x];
      if (xr < 0 || r[xr] == kInvalidDisparity || std::abs(r[xr] - l[x]) > max_diff)
        l[x] = kInvalidDisparity;
    }
  }
}

void uniqueness_check(ImageView<std::int16_t> disparity, ImageView<const std::uint16_t> best,
                      ImageView<const std::uint16_t> second, double ratio) {
  const double keep = 1.0 - ratio;  // kept when best <= keep * second
  for (int y = 0; y < disparity.height; ++y) {
    std::int16_t* d = disparity.row(y);
    const std::uint16_t* b = best.row(y);
    const std::uint16_t* s = second.row(y);
    for (int x = 0; x < disparity.width; ++x) {
      if (d[x] == kInvalidDisparity || s[x] == WinnerTakesAll::kNoCost) continue;
      if (static_cast<double>(b[x]) > keep * static_cast<double>(s[x])) d[x] = kInvalidDisparity;
    }
  }
}

void discontinuity_check(ImageView<std::int16_t> disparity, int max_jump,
                         Image<std::int16_t>& scratch) {
  const int w = disparity.width;
  const int h = disparity.height;
  scratch.resize(w, h);
  scratch.copy_from(disparity);
  for (int y = 0; y < h; ++y) {
    std::int16_t* out = disparity.row(y);
    for (int x = 0; x < w; ++x) {
      const int d = scratch.at(x, y);
      if (d == kInvalidDisparity) continue;
      bool jump = false;
      for (int ny = std::max(y - 1, 0); ny <= std::min(y + 1, h - 1) && !jump; ++ny) {
        const std::int16_t* row = scratch.row(ny);
        for (int nx = std::max(x - 1, 0); nx <= std::min(x + 1, w - 1); ++nx)
          if (row[nx] != kInvalidDisparity && std::abs(row[nx] - d) > max_jump) {
            jump = true;
            break;
          }
      }
      if (jump) out[x] = kInvalidDisparity;
    }
  }
}

}  // namespace dco::stereo
