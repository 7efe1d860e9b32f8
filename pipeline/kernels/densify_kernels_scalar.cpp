#include "dco/kernels/densify_kernels.hpp"
#include "densify_ranges.hpp"

namespace dco::kernels::scalar {

void grid_smooth_row(const GridRow& row, int start, const float* b, float* x) {
  detail::smooth_range(row, start, b, x, 0, row.width);
}

void grid_apply_row(const GridRow& row, const float* x, float* out) {
  detail::apply_range(row, x, out, 0, row.width);
}

double dot_row(const float* a, const float* b, int n) {
  constexpr int kLanes = detail::kDotLanes;
  float partial[kLanes] = {};
  int i = 0;
  for (; i + kLanes <= n; i += kLanes)
    for (int lane = 0; lane < kLanes; ++lane) partial[lane] += a[i + lane] * b[i + lane];
  return detail::finish_dot(a, b, i, n, partial);
}

}  // namespace dco::kernels::scalar
