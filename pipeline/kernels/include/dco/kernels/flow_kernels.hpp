#pragma once

#include <cstddef>
#include <cstdint>

// Row kernels of the contour stage's flow cue (dco::contour::projection_contrast). Every function
// in dco::kernels dispatches at run time to the best SIMD target (see stereo_kernels.hpp); the
// functions of the same name in dco::kernels::scalar are the plain references. The vector
// versions do the same float operations in the same order (no fused multiply-add, IEEE square
// root and division), so their results are bit-identical to the references.
namespace dco::kernels {

// A two-channel flow field (u, v interleaved), `stride` floats between rows.
struct FlowField {
  const float* data = nullptr;
  std::ptrdiff_t stride = 0;
  int width = 0, height = 0;
};

// contrast[x] for the pixels of row y: the flow, projected on its own direction e, at the point
// `distance` ahead along e minus at the point as far behind (Eq. 9–11), both bilinearly sampled
// and clamped to the field; 0 where the flow is shorter than min_length.
void projection_contrast_row(const FlowField& flow, int y, float distance, float min_length,
                             float* contrast);

// Where the pixels of row y land in the field's other frame: (column[x], row[x]) = the floor of
// (x + u + 0.5, y + v + 0.5), the nearest pixel to (x + u, y + v), or column[x] = -1 where that
// lies outside the field or the flow is not a number; speed[x] = u * u + v * v.
void flow_targets_row(const FlowField& flow, int y, std::int32_t* column, std::int32_t* row,
                      float* speed);

namespace scalar {
void projection_contrast_row(const FlowField& flow, int y, float distance, float min_length,
                             float* contrast);
void flow_targets_row(const FlowField& flow, int y, std::int32_t* column, std::int32_t* row,
                      float* speed);
}  // namespace scalar

}  // namespace dco::kernels
