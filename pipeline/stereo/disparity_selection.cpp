#include "dco/pipeline/stereo/disparity_selection.hpp"

#include <algorithm>
#include <cassert>
#include <cstdlib>

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
  const int w = slice.width;
  const auto dd = static_cast<std::int16_t>(d);
  for (int y = 0; y < slice.height; ++y) {
    const std::uint32_t* c_row = slice.row(y);
    std::uint16_t* best = best_.row(y);
    std::uint16_t* second = second_.row(y);
    std::uint16_t* below = below_.row(y);
    std::uint16_t* above = above_.row(y);
    std::uint16_t* prev1 = prev1_.row(y);
    std::uint16_t* prev2 = prev2_.row(y);
    std::uint16_t* runmin = runmin_.row(y);
    std::int16_t* disp = disp_.row(y);
    std::uint16_t* best_r = best_right_.row(y);
    std::int16_t* disp_r = disp_right_.row(y);
    for (int x = 0; x < w; ++x) {
      assert(c_row[x] < kNoCost);
      const auto c = static_cast<std::uint16_t>(c_row[x]);
      runmin[x] = std::min(runmin[x], prev2[x]);  // best over disparities <= d - 2
      if (c < best[x]) {
        best[x] = c;
        disp[x] = dd;
        second[x] = runmin[x];
        below[x] = prev1[x];
        above[x] = kNoCost;
      } else if (d == disp[x] + 1) {
        above[x] = c;
      } else {
        second[x] = std::min(second[x], c);
      }
      prev2[x] = prev1[x];
      prev1[x] = c;
      if (x >= d && c < best_r[x - d]) {
        best_r[x - d] = c;
        disp_r[x - d] = dd;
      }
    }
  }
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
