#pragma once

// The scalar Canny classification over a range of columns: the whole row for
// dco::kernels::scalar, the last partial vector for the SIMD version.

#include "dco/kernels/canny_kernels.hpp"
#include "dco/kernels/contour_pixel.hpp"

namespace dco::kernels::detail {

inline void canny_classify_range(const CannyRow& r, const CannyLevels& t, int begin, int end,
                                 std::uint8_t* out) {
  for (int x = begin; x < end; ++x)
    out[x] = pixel::canny_class(r.above, r.row, r.below, r.direction[x], r.gate != nullptr,
                                r.gate != nullptr ? r.gate[x] : 0.0f, x, t);
}

}  // namespace dco::kernels::detail
