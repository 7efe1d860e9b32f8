#pragma once

// The scalar Canny classification and gate over a range of columns: the whole row for
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

inline void canny_gate_range(const std::uint8_t* classes, const float* gate, float depth, int begin,
                             int end, std::uint8_t* out) {
  for (int x = begin; x < end; ++x) out[x] = gate[x] < depth ? kCannyNone : classes[x];
}

}  // namespace dco::kernels::detail
