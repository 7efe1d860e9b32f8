#pragma once

// The scalar Canny classification over a range of columns: the whole row for
// dco::kernels::scalar, the last partial vector for the SIMD version.

#include "dco/kernels/canny_kernels.hpp"

namespace dco::kernels::detail {

inline void canny_classify_range(const CannyRow& r, const CannyLevels& t, int begin, int end,
                                 std::uint8_t* out) {
  for (int x = begin; x < end; ++x) {
    const float v = r.row[x];
    out[x] = kCannyNone;
    if (v < t.low) continue;
    if (r.gate != nullptr && r.gate[x] < t.depth) continue;
    float before = 0, after = 0;
    switch (r.direction[x]) {
      case 0:
        before = r.row[x - 1], after = r.row[x + 1];
        break;
      case 1:
        before = r.above[x - 1], after = r.below[x + 1];
        break;
      case 2:
        before = r.above[x], after = r.below[x];
        break;
      default:
        before = r.below[x - 1], after = r.above[x + 1];
        break;
    }
    if (!(v > before && v >= after)) continue;
    out[x] = v > t.high ? kCannyStrong : kCannyWeak;
  }
}

}  // namespace dco::kernels::detail
