#include "dco/kernels/filter_kernels.hpp"
#include "filter_ranges.hpp"

namespace dco::kernels {

void repeat_pairs(const float* __restrict in, int width, float* __restrict out) {
  const int pairs = width / 2;
  for (int i = 0; i < pairs; ++i) {
    out[2 * i] = in[i];
    out[2 * i + 1] = in[i];
  }
  if (width % 2 != 0) out[width - 1] = in[pairs];
}

}  // namespace dco::kernels

namespace dco::kernels::scalar {

void median5_row(const float* const rows[5], int width, float* out) {
  detail::median5_range(rows, width, 0, width, out);
}

void gaussian5_vertical_row(const std::uint8_t* const rows[5], const float* taps, int width,
                            float* out) {
  detail::gaussian5_vertical_range(rows, taps, 0, width, out);
}

void row_filter(const float* in, int width, const float* taps, int radius, float* out) {
  detail::row_filter_range(in, width, taps, radius, 0, width, out);
}

void box_vertical_row(const float* in, std::ptrdiff_t stride, int height, int y, int size,
                      float inv, int width, float* out) {
  detail::box_vertical_range(in, stride, height, y, size, inv, 0, width, out);
}

void sobel_row(const SobelRows& rows, float inv_norm, float* magnitude, std::uint8_t* direction) {
  detail::sobel_range(rows, inv_norm, 0, rows.width, magnitude, direction);
}

}  // namespace dco::kernels::scalar
