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
  diagonal_.resize(width, 2);
  residual_.resize(2 * half_, 1);
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
  split(a.wx.row(r), kWx);
  split(a.wy.row(r), kWy);
  if (a.has_diagonal) {
    split(a.diag.row(r), kDiag);
    for (int parity = 0; parity < 2; ++parity)
      kernels::inverse_diagonal_row(array(r, kDiag, parity), kernels::parity_count(width_, parity),
                                    array(r, kInvDiag, parity));
    return;
  }
  // The diagonal row and its inverse together, as GridSystem::update_diagonal_rows makes them.
  kernels::diagonal_row(a.data.row(r), a.wx.row(r), r + 1 < height_ ? a.wy.row(r) : nullptr,
                        r > 0 ? a.wy.row(r - 1) : nullptr, width_, diagonal_.row(0),
                        diagonal_.row(1));
  split(diagonal_.row(0), kDiag);
  split(diagonal_.row(1), kInvDiag);
}

kernels::SplitSmoothRow SweepRows::smooth_row(int r, int parity) const {
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
  return row;
}

void SweepRows::smooth(int r, int parity) {
  kernels::grid_smooth_split_row(smooth_row(r, parity), array(r, kX, parity));
}

void SweepRows::residual(int r, float* out) {
  float* split[2] = {residual_.row(0), residual_.row(0) + half_};
  for (int parity = 0; parity < 2; ++parity)
    kernels::split_residual_row(
        {smooth_row(r, parity), array(r, kDiag, parity), array(r, kX, parity)}, split[parity]);
  kernels::merge_row(split[0], split[1], width_, out);
}

void SweepRows::store(int r, ImageView<float> x) const {
  kernels::merge_row(array(r, kX, 0), array(r, kX, 1), width_, x.row(r));
}

}  // namespace dco::densify
