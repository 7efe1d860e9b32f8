#pragma once

// The scalar flow kernels over a range of columns: the whole row for dco::kernels::scalar, the
// last partial vector for the SIMD versions. The order of the float operations here is the
// contract the vector code follows.

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "dco/kernels/flow_kernels.hpp"

namespace dco::kernels::detail {

struct FlowSample {
  float u, v;
};

// Bilinear sample of the field at (px, py), already clamped to it.
inline FlowSample sample_flow(const FlowField& f, float px, float py) {
  const int x0 = static_cast<int>(px);
  const int y0 = static_cast<int>(py);
  const int x1 = std::min(x0 + 1, f.width - 1);
  const int y1 = std::min(y0 + 1, f.height - 1);
  const float fx = px - static_cast<float>(x0);
  const float fy = py - static_cast<float>(y0);
  const float* r0 = f.data + y0 * f.stride;
  const float* r1 = f.data + y1 * f.stride;
  const float w00 = (1 - fx) * (1 - fy), w10 = fx * (1 - fy), w01 = (1 - fx) * fy, w11 = fx * fy;
  return {
      w00 * r0[2 * x0] + w10 * r0[2 * x1] + w01 * r1[2 * x0] + w11 * r1[2 * x1],
      w00 * r0[2 * x0 + 1] + w10 * r0[2 * x1 + 1] + w01 * r1[2 * x0 + 1] + w11 * r1[2 * x1 + 1]};
}

inline void projection_contrast_range(const FlowField& f, int y, float distance, float min_length,
                                      int begin, int end, float* contrast) {
  const float max_x = static_cast<float>(f.width - 1);
  const float max_y = static_cast<float>(f.height - 1);
  const float* row = f.data + y * f.stride;
  for (int x = begin; x < end; ++x) {
    const float u = row[2 * x];
    const float v = row[2 * x + 1];
    const float len = std::sqrt(u * u + v * v);
    if (len < min_length) {
      contrast[x] = 0.0f;
      continue;
    }
    const float ex = u / len;
    const float ey = v / len;
    const float dx = distance * ex;
    const float dy = distance * ey;
    const FlowSample f0 = sample_flow(f, std::clamp(static_cast<float>(x) - dx, 0.0f, max_x),
                                      std::clamp(static_cast<float>(y) - dy, 0.0f, max_y));
    const FlowSample f1 = sample_flow(f, std::clamp(static_cast<float>(x) + dx, 0.0f, max_x),
                                      std::clamp(static_cast<float>(y) + dy, 0.0f, max_y));
    contrast[x] = (f1.u * ex + f1.v * ey) - (f0.u * ex + f0.v * ey);
  }
}

inline void flow_targets_range(const FlowField& f, int y, int begin, int end, std::int32_t* column,
                               std::int32_t* row, float* speed) {
  const float* r = f.data + y * f.stride;
  const float w = static_cast<float>(f.width);
  const float h = static_cast<float>(f.height);
  for (int x = begin; x < end; ++x) {
    const float u = r[2 * x];
    const float v = r[2 * x + 1];
    const float tx = static_cast<float>(x) + u + 0.5f;
    const float ty = static_cast<float>(y) + v + 0.5f;
    // Also false for NaN; inside these bounds the truncation is the floor.
    const bool inside = tx >= 0.0f && tx < w && ty >= 0.0f && ty < h;
    column[x] = inside ? static_cast<std::int32_t>(tx) : -1;
    row[x] = inside ? static_cast<std::int32_t>(ty) : 0;
    speed[x] = u * u + v * v;
  }
}

}  // namespace dco::kernels::detail
