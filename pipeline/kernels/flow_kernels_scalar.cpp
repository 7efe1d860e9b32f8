#include "dco/kernels/flow_kernels.hpp"
#include "flow_ranges.hpp"

namespace dco::kernels::scalar {

void projection_contrast_row(const FlowField& flow, int y, float distance, float min_length,
                             float* contrast) {
  detail::projection_contrast_range(flow, y, distance, min_length, 0, flow.width, contrast);
}

}  // namespace dco::kernels::scalar
