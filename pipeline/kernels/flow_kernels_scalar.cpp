#include "dco/kernels/flow_kernels.hpp"
#include "flow_ranges.hpp"

namespace dco::kernels::scalar {

void projection_contrast_row(const FlowField& flow, int y, float distance, float min_length,
                             float* contrast) {
  detail::projection_contrast_range(flow, y, distance, min_length, 0, flow.width, contrast);
}

void flow_targets_row(const FlowField& flow, int y, std::int32_t* column, std::int32_t* row,
                      float* speed) {
  detail::flow_targets_range(flow, y, 0, flow.width, column, row, speed);
}

}  // namespace dco::kernels::scalar
