#include "dco/kernels/densify_kernels.hpp"

#include <algorithm>
#include <cstddef>

#include "dco/kernels/densify_pixel.hpp"
#include "densify_ranges.hpp"

namespace dco::kernels::scalar {

void hole_hint_row(const float* sparse, const float* wx, int width, float crossing, float* hint) {
  // Whether the path to a value crosses a weak edge is a flag carried along the row, reset at
  // every known pixel; the left pass keeps its flag in the sign of the hint (see the kernel).
  float last = 0.0f;
  bool crossed = false;
  for (int x = 0; x < width; ++x) {
    const bool k = pixel::known_value(sparse[x]);
    last = k ? sparse[x] : last;
    crossed = !k && crossed;
    if (!k) hint[x] = crossed ? -last : last;
    crossed = crossed || (x + 1 < width && wx[x] < crossing);
  }
  last = 0.0f;
  crossed = false;
  for (int x = width - 1; x >= 0; --x) {
    const bool k = pixel::known_value(sparse[x]);
    last = k ? sparse[x] : last;
    crossed = !k && crossed;
    if (!k) hint[x] = pixel::hole_hint(hint[x], last, crossed);
    if (x > 0) crossed = crossed || wx[x - 1] < crossing;
  }
}

int occlusion_fill_row(const float* sparse, const float* hint, int width, const OcclusionRule& rule,
                       float* data, float* b) {
  int weighted = 0;
  int prev_start = -1, prev_end = -1;  // the previous run: known left neighbour, no strip
  int x = 0;
  while (x < width && !pixel::known_value(sparse[x])) ++x;  // a run at the row start
  while (x < width) {
    while (x < width && pixel::known_value(sparse[x])) ++x;
    const int start = x;
    while (x < width && !pixel::known_value(sparse[x])) ++x;
    if (x == width) break;  // a run at the row end
    weighted +=
        pixel::fill_occlusion_run(sparse, hint, start, x, rule, data, b, prev_start, prev_end);
  }
  return weighted;
}

void data_terms_row(const float* sparse, const float* hint, const float* previous, int width,
                    const DataTermRule& rule, float* data, float* b, float* low, float* high) {
  detail::data_terms_range(sparse, hint, previous, rule, 0, width, data, b, low, high);
}

void diagonal_row(const float* data, const float* wx, const float* wy, const float* wy_above,
                  int width, float* diag, float* inv_diag) {
  detail::diagonal_range(data, wx, wy, wy_above, width, 0, width, diag, inv_diag);
}

void edge_weights_row(const EdgeEnds& ends, const EdgeRule& rule, int n, float* out) {
  detail::edge_range(ends, rule, 0, n, out);
}

void grid_smooth_row(const GridRow& row, int start, const float* b, float* x) {
  detail::smooth_range(row, start, b, x, 0, row.width);
}

void grid_apply_row(const GridRow& row, const float* x, float* out) {
  detail::apply_range(row, x, out, 0, row.width);
}

void grid_smooth_split_row(const SplitSmoothRow& row, float* x) {
  detail::smooth_split_range(row, x, 0, parity_count(row.width, row.parity));
}

void split_residual_row(const SplitResidualRow& row, float* out) {
  detail::residual_split_range(row, out, 0, parity_count(row.row.width, row.row.parity));
}

void inverse_diagonal_row(const float* diag, int n, float* inv) {
  detail::inverse_diagonal_range(diag, 0, n, inv);
}

void split_row(const float* in, int width, float* even, float* odd) {
  detail::split_range(in, width, 0, parity_count(width, 0), even, odd);
}

void merge_row(const float* even, const float* odd, int width, float* out) {
  detail::merge_range(even, odd, width, 0, parity_count(width, 0), out);
}

double dot_row(const float* a, const float* b, int n) {
  return pixel::dot_row(a, b, n);
}

void match_plane_row(const float* sums, const float* own, int n, const MatchPlaneRule& rule,
                     float* plane) {
  const auto at = [&](int k, int i) { return sums[static_cast<std::ptrdiff_t>(k) * n + i]; };
  for (int i = 0; i < n; ++i)
    plane[i] = pixel::match_plane(at(0, i), at(1, i), at(2, i), at(3, i), at(4, i), at(5, i),
                                  at(6, i), at(7, i), at(8, i), at(9, i), own[i], rule);
}

void match_plane_select_half_row(const float* sparse, const float* own, const float* plane,
                                 int width, float* out) {
  for (int x = 0; x < width; ++x)
    out[x] = pixel::match_plane_select(sparse[x], own[x / 2], plane[x / 2]);
}

void match_plane_row_sums(const float* match, const float* d, const float* dd, int n, int radius,
                          float* sums) {
  std::fill(sums, sums + 6 * static_cast<std::ptrdiff_t>(n), 0.0f);
  for (int k = -radius; k <= radius; ++k) {
    const auto fk = static_cast<float>(k);
    const float fk2 = fk * fk;
    for (int x = std::max(0, -k); x < std::min(n, n - k); ++x)
      pixel::match_plane_row_step(match[x + k], d[x + k], dd[x + k], fk, fk2, sums + x, n);
  }
}

void match_plane_window_sums(const float* const* rows, int radius, int n, float* sums) {
  std::fill(sums, sums + 10 * static_cast<std::ptrdiff_t>(n), 0.0f);
  for (int j = -radius; j <= radius; ++j) {
    const float* r = rows[j + radius];
    if (r == nullptr) continue;
    const auto v = static_cast<float>(j);
    for (int x = 0; x < n; ++x) pixel::match_plane_window_step(r + x, v, v * v, n, sums + x);
  }
}

void match_plane_window_slide(const float* const* rows, const float* left, int radius, int n,
                              float* sums) {
  detail::match_plane_window_slide_range(rows, left, radius, n, 0, n, sums);
}

}  // namespace dco::kernels::scalar
