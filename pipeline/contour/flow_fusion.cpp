#include "dco/pipeline/contour/flow_fusion.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "dco/kernels/flow_kernels.hpp"

namespace dco::contour {
void flow_amplitude(ImageView<const float> flow, ImageView<float> speed,
                    ImageView<float> amplitude) {
  assert(flow.channels == 2 && speed.same_size(flow) && amplitude.same_size(flow));
  const int w = flow.width;
  const int h = flow.height;
  for (int y = 0; y < h; ++y) {
    const float* f = flow.row(y);
    float* r = speed.row(y);
    for (int x = 0; x < w; ++x) r[x] = std::sqrt(f[2 * x] * f[2 * x] + f[2 * x + 1] * f[2 * x + 1]);
  }
  for (int y = 0; y < h; ++y) {
    const float* r = speed.row(y);
    const float* below = speed.row(std::min(y + 1, h - 1));  // the last row differs from itself: 0
    float* m = amplitude.row(y);
    for (int x = 0; x < w - 1; ++x)
      m[x] = std::max(std::fabs(r[x + 1] - r[x]), std::fabs(below[x] - r[x]));
    m[w - 1] = std::fabs(below[w - 1] - r[w - 1]);
  }
}

void projection_contrast(ImageView<const float> flow, float distance, ImageView<float> contrast) {
  assert(flow.channels == 2 && contrast.same_size(flow));
  const kernels::FlowField field{flow.data, flow.stride, flow.width, flow.height};
  for (int y = 0; y < flow.height; ++y)
    kernels::projection_contrast_row(field, y, distance, kMinFlowForDirection, contrast.row(y));
}

void fuse_amplitudes(ImageView<const float> amplitude_a, ImageView<const float> contrast_a,
                     ImageView<const float> amplitude_b, ImageView<const float> contrast_b,
                     ImageView<float> fused) {
  assert(contrast_a.same_size(amplitude_a) && amplitude_b.same_size(amplitude_a) &&
         contrast_b.same_size(amplitude_a) && fused.same_size(amplitude_a));
  for (int y = 0; y < fused.height; ++y) {
    const float* ma = amplitude_a.row(y);
    const float* ca = contrast_a.row(y);
    const float* mb = amplitude_b.row(y);
    const float* cb = contrast_b.row(y);
    float* out = fused.row(y);
    for (int x = 0; x < fused.width; ++x) out[x] = ca[x] > cb[x] ? ma[x] : mb[x];
  }
}

float normalise_by_max(ImageView<float> values, float floor) {
  float largest = 0.0f;
  for (int y = 0; y < values.height; ++y) {
    const float* r = values.row(y);
    for (int x = 0; x < values.width; ++x) largest = std::max(largest, r[x]);
  }
  const float divisor = std::max(largest, floor);
  if (divisor <= 0.0f) return 0.0f;
  const float inv = 1.0f / divisor;
  for (int y = 0; y < values.height; ++y) {
    float* r = values.row(y);
    for (int x = 0; x < values.width; ++x) r[x] = std::min(r[x] * inv, 1.0f);
  }
  return divisor;
}

}  // namespace dco::contour
