#include "dco/kernels/densify_kernels.hpp"
#include "dco/kernels/densify_pixel.hpp"
#include "densify_ranges.hpp"

namespace dco::kernels::scalar {

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

double dot_row(const float* a, const float* b, int n) {
  return pixel::dot_row(a, b, n);
}

}  // namespace dco::kernels::scalar
