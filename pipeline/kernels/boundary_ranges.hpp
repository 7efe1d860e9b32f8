#pragma once

// The scalar sides of the boundary refinement over a range of columns: the whole row for
// dco::kernels::scalar, the last partial vector for the SIMD versions. The order of the
// comparisons here is the contract the vector code follows.

#include "dco/kernels/boundary_kernels.hpp"
#include "dco/kernels/stereo_pixel.hpp"

namespace dco::kernels::detail {

inline void boundary_column_sides_range(const float* const* rows, int count, int begin, int end,
                                        float* far, float* near) {
  const float none = pixel::infinity();
  for (int x = begin; x < end; ++x) {
    float lo = none, hi = -none;
    for (int k = 0; k < count; ++k) {
      const float v = rows[k][x];
      if (!(v < none)) continue;
      lo = v < lo ? v : lo;
      hi = v > hi ? v : hi;
    }
    far[x] = lo;
    near[x] = hi;
  }
}

inline void boundary_row_sides_range(const float* lo, const float* hi, int reach, int narrow_reach,
                                     int begin, int end, float* far, float* near, float* narrow_far,
                                     float* narrow_near) {
  const int inner = narrow_far != nullptr ? narrow_reach : reach;
  for (int x = begin; x < end; ++x) {
    float f = lo[x - inner], g = hi[x - inner];
    for (int o = -inner + 1; o <= inner; ++o) {
      f = lo[x + o] < f ? lo[x + o] : f;
      g = hi[x + o] > g ? hi[x + o] : g;
    }
    if (narrow_far != nullptr) {
      narrow_far[x] = f;
      narrow_near[x] = g;
      for (int o = -reach; o <= reach; ++o) {
        if (o >= -inner && o <= inner) continue;
        f = lo[x + o] < f ? lo[x + o] : f;
        g = hi[x + o] > g ? hi[x + o] : g;
      }
    }
    far[x] = f;
    near[x] = g;
  }
}

}  // namespace dco::kernels::detail
