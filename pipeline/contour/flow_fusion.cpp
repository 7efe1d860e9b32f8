#include "dco/pipeline/contour/flow_fusion.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace dco::contour {
namespace {

struct Flow {
  float u, v;
};

// Bilinear sample of a 2-channel field at (px, py), already clamped to the image.
inline Flow sample(ImageView<const float> flow, float px, float py) {
  const int x0 = static_cast<int>(px);
  const int y0 = static_cast<int>(py);
  const int x1 = std::min(x0 + 1, flow.width - 1);
  const int y1 = std::min(y0 + 1, flow.height - 1);
  const float fx = px - static_cast<float>(x0);
  const float fy = py - static_cast<float>(y0);
  const float* r0 = flow.row(y0);
  const float* r1 = flow.row(y1);
  const float w00 = (1 - fx) * (1 - fy), w10 = fx * (1 - fy), w01 = (1 - fx) * fy, w11 = fx * fy;
  return {
      w00 * r0[2 * x0] + w10 * r0[2 * x1] + w01 * r1[2 * x0] + w11 * r1[2 * x1],
      w00 * r0[2 * x0 + 1] + w10 * r0[2 * x1 + 1] + w01 * r1[2 * x0 + 1] + w11 * r1[2 * x1 + 1]};
}

}  // namespace

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
  const float max_x = static_cast<float>(flow.width - 1);
  const float max_y = static_cast<float>(flow.height - 1);
  for (int y = 0; y < flow.height; ++y) {
    const float* f = flow.row(y);
    float* c = contrast.row(y);
    for (int x = 0; x < flow.width; ++x) {
      const float u = f[2 * x];
      const float v = f[2 * x + 1];
      const float len = std::sqrt(u * u + v * v);
      if (len < kMinFlowForDirection) {
        c[x] = 0.0f;
        continue;
      }
      const float ex = u / len;
      const float ey = v / len;
      const float dx = distance * ex;
      const float dy = distance * ey;
      const Flow f0 = sample(flow, std::clamp(static_cast<float>(x) - dx, 0.0f, max_x),
                             std::clamp(static_cast<float>(y) - dy, 0.0f, max_y));
      const Flow f1 = sample(flow, std::clamp(static_cast<float>(x) + dx, 0.0f, max_x),
                             std::clamp(static_cast<float>(y) + dy, 0.0f, max_y));
      c[x] = (f1.u * ex + f1.v * ey) - (f0.u * ex + f0.v * ey);
    }
  }
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
