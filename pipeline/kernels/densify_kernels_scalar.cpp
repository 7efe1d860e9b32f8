#include "dco/kernels/densify_kernels.hpp"
#include "dco/kernels/densify_pixel.hpp"
#include "densify_ranges.hpp"

namespace dco::kernels::scalar {

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
