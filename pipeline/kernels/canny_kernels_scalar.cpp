#include "canny_ranges.hpp"
#include "dco/kernels/canny_kernels.hpp"

namespace dco::kernels::scalar {

void canny_classify_row(const CannyRow& row, const CannyLevels& levels, std::uint8_t* out) {
  if (row.width <= 0) return;
  out[0] = kCannyNone;
  if (row.width == 1) return;
  detail::canny_classify_range(row, levels, 1, row.width - 1, out);
  out[row.width - 1] = kCannyNone;
}

void canny_gate_row(const std::uint8_t* classes, const float* gate, float depth, int width,
                    std::uint8_t* out) {
  detail::canny_gate_range(classes, gate, depth, 0, width, out);
}

}  // namespace dco::kernels::scalar
