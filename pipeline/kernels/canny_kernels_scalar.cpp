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

}  // namespace dco::kernels::scalar
