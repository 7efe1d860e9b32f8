#include "dco/pipeline/densify/sweep_rows.hpp"

#include <algorithm>
#include <utility>

namespace dco::densify {

void SweepRows::start(int width, int height, int slots) {
  width_ = width;
  height_ = height;
  slots_ = std::clamp(slots, 1, std::max(1, height));
  constexpr int kLineFloats = static_cast<int>(Image<float>::kAlignment / sizeof(float));
  half_ = (kernels::parity_count(width, 0) + kLineFloats - 1) / kLineFloats * kLineFloats;
  ring_.resize(2 * kArrays * half_, slots_);
  spare_.resize(width, 1);
}

float* SweepRows::array(int r, Array a, int parity) {
  return const_cast<float*>(std::as_const(*this).array(r, a, parity));
}

const float* SweepRows::array(int r, Array a, int parity) const {
  return ring_.row(r % slots_) + (2 * a + parity) * half_;
}

void SweepRows::load(const GridSystem& a, ImageView<const float> b, ImageView<const float> x,
                     int r) {
  const auto split = [&](const float* in, Array to) {
    kernels::split_row(in, width_, array(r, to, 0), array(r, to, 1));
  };
  split(x.row(r), kX);
  split(b.row(r), kB);
  split(a.inv_diag.row(r), kInvDiag);
  split(a.wx.row(r), kWx);
  split(a.wy.row(r), kWy);
}

void SweepRows::smooth(int r, int parity) {
  const int other = 1 - parity;
  kernels::SplitSmoothRow row;
  row.width = width_;
  row.parity = parity;
  row.b = array(r, kB, parity);
  row.inv_diag = array(r, kInvDiag, parity);
  row.wx = array(r, kWx, parity);
  row.wx_other = array(r, kWx, other);
  row.x_other = array(r, kX, other);
  if (r + 1 < height_) {
    row.wy = array(r, kWy, parity);
    row.x_below = array(r + 1, kX, parity);
  }
  if (r > 0) {
    row.wy_above = array(r - 1, kWy, parity);
    row.x_above = array(r - 1, kX, parity);
  }
  kernels::grid_smooth_split_row(row, array(r, kX, parity));
}

void SweepRows::store(int r, ImageView<float> x) const {
  kernels::merge_row(array(r, kX, 0), array(r, kX, 1), width_, x.row(r));
}

}  // namespace dco::densify
