#include "dco/pipeline/contour/separable_filters.hpp"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>

#include "dco/kernels/filter_kernels.hpp"

namespace dco::contour {
namespace {

std::array<float, 5> make_gaussian_taps() {
  constexpr double kSigma = 1.4;
  std::array<double, 5> w{};
  double sum = 0;
  for (int i = 0; i < 5; ++i) {
    const double d = i - 2;
    w[i] = std::exp(-d * d / (2 * kSigma * kSigma));
    sum += w[i];
  }
  std::array<float, 5> taps{};
  for (int i = 0; i < 5; ++i) taps[i] = static_cast<float>(w[i] / sum);
  return taps;
}

}  // namespace

const std::array<float, 5>& gaussian5_taps() {
  static const std::array<float, 5> taps = make_gaussian_taps();
  return taps;
}

void gaussian_blur_5x5(ImageView<const std::uint8_t> in, ImageView<float> tmp,
                       ImageView<float> out) {
  assert(in.channels == 1 && tmp.same_size(in) && out.same_size(in));
  for (int y = 0; y < in.height; ++y) gaussian_blur_5x5_row(in, y, tmp.row(y), out.row(y));
}

void gaussian_blur_5x5_row(ImageView<const std::uint8_t> in, int y, float* tmp_row,
                           float* out_row) {
  assert(in.channels == 1);
  const std::array<float, 5>& taps = gaussian5_taps();
  const int h = in.height;
  const std::uint8_t* const rows[5] = {in.row(std::max(y - 2, 0)), in.row(std::max(y - 1, 0)),
                                       in.row(y), in.row(std::min(y + 1, h - 1)),
                                       in.row(std::min(y + 2, h - 1))};
  kernels::gaussian5_vertical_row(rows, taps.data(), in.width, tmp_row);
  kernels::row_filter(tmp_row, in.width, taps.data(), 2, out_row);
}

namespace {
constexpr int kMaxBoxSize = 255;
}  // namespace

void box_filter(ImageView<const float> in, int size, ImageView<float> tmp, ImageView<float> out) {
  box_vertical_rows(in, size, 0, in.height, tmp);
  box_horizontal_rows(tmp, size, 0, in.height, out);
}

void box_vertical_rows(ImageView<const float> in, int size, int y_begin, int y_end,
                       ImageView<float> tmp) {
  assert(size >= 1 && size % 2 == 1 && size <= kMaxBoxSize && in.channels == 1);
  assert(tmp.same_size(in));
  const float inv = 1.0f / static_cast<float>(size);
  // Every output row is the mean of `size` clamped input rows.
  for (int y = y_begin; y < y_end; ++y)
    kernels::box_vertical_row(in.data, in.stride, in.height, y, size, inv, in.width, tmp.row(y));
}

void box_horizontal_rows(ImageView<const float> tmp, int size, int y_begin, int y_end,
                         ImageView<float> out) {
  assert(size >= 1 && size % 2 == 1 && size <= kMaxBoxSize && tmp.channels == 1);
  assert(out.same_size(tmp));
  const float inv = 1.0f / static_cast<float>(size);
  std::array<float, kMaxBoxSize> taps{};
  for (int k = 0; k < size; ++k) taps[k] = inv;
  for (int y = y_begin; y < y_end; ++y)
    kernels::row_filter(tmp.row(y), tmp.width, taps.data(), size / 2, out.row(y));
}

}  // namespace dco::contour
