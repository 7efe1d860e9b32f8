#include "boundary_ranges.hpp"
#include "dco/kernels/boundary_kernels.hpp"

namespace dco::kernels::scalar {

void boundary_column_sides(const float* const* rows, int count, int width, float* far,
                           float* near) {
  detail::boundary_column_sides_range(rows, count, 0, width, far, near);
}

void boundary_row_sides(const float* lo, const float* hi, int width, int reach, int narrow_reach,
                        float* far, float* near, float* narrow_far, float* narrow_near) {
  detail::boundary_row_sides_range(lo, hi, reach, narrow_reach, 0, width, far, near, narrow_far,
                                   narrow_near);
}

}  // namespace dco::kernels::scalar
