#include "dco/pipeline/stereo/census.hpp"

#include <algorithm>
#include <array>
#include <cassert>

#include "dco/kernels/stereo_kernels.hpp"

namespace dco::stereo {

void census_transform(ImageView<const std::uint8_t> gray, int window_w, int window_h,
                      ImageView<std::uint64_t> out) {
  census_transform_rows(gray, window_w, window_h, 0, gray.height, out);
}

void census_transform_rows(ImageView<const std::uint8_t> gray, int window_w, int window_h,
                           int y_begin, int y_end, ImageView<std::uint64_t> out) {
  assert(gray.channels == 1 && out.same_size(gray));
  assert(window_w % 2 == 1 && window_h % 2 == 1 && window_w * window_h - 1 <= 64);
  const int ry = window_h / 2;
  const int h = gray.height;
  std::array<const std::uint8_t*, 65> rows{};  // window_h <= 65 rows (a 1-wide window)
  for (int y = y_begin; y < y_end; ++y) {
    for (int j = 0; j < window_h; ++j) rows[j] = gray.row(std::clamp(y + j - ry, 0, h - 1));
    kernels::census_row(rows.data(), gray.width, window_w, window_h, out.row(y));
  }
}

}  // namespace dco::stereo
