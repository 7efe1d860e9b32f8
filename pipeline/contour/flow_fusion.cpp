#include "dco/pipeline/contour/flow_fusion.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "dco/kernels/flow_kernels.hpp"

namespace dco::contour {
void flow_amplitude(ImageView<const float> flow, ImageView<float> speed,
                    ImageView<float> amplitude) {
  assert(flow.channels == 2 && speed.same_size(flow) && amplitude.same_size(flow));
  flow_speed_rows(flow, 0, flow.height, speed);
  flow_amplitude_rows(speed, 0, flow.height, amplitude);
}

void flow_speed_rows(ImageView<const float> flow, int y_begin, int y_end, ImageView<float> speed) {
  assert(flow.channels == 2 && speed.same_size(flow));
  const int w = flow.width;
  for (int y = y_begin; y < y_end; ++y) {
    const float* f = flow.row(y);
    float* r = speed.row(y);
    for (int x = 0; x < w; ++x) r[x] = std::sqrt(f[2 * x] * f[2 * x] + f[2 * x + 1] * f[2 * x + 1]);
  }
}

void flow_amplitude_rows(ImageView<const float> speed, int y_begin, int y_end,
                         ImageView<float> amplitude) {
  assert(amplitude.same_size(speed));
  const int w = speed.width;
  const int h = speed.height;
  for (int y = y_begin; y < y_end; ++y) {
    const float* r = speed.row(y);
    const float* below = speed.row(std::min(y + 1, h - 1));  // the last row differs from itself: 0
    float* m = amplitude.row(y);
    for (int x = 0; x < w - 1; ++x)
      m[x] = std::max(std::fabs(r[x + 1] - r[x]), std::fabs(below[x] - r[x]));
    m[w - 1] = std::fabs(below[w - 1] - r[w - 1]);
  }
}

void projection_contrast(ImageView<const float> flow, float distance, ImageView<float> contrast) {
  projection_contrast_rows(flow, distance, 0, flow.height, contrast);
}

void projection_contrast_rows(ImageView<const float> flow, float distance, int y_begin, int y_end,
                              ImageView<float> contrast) {
  assert(flow.channels == 2 && contrast.same_size(flow));
  const kernels::FlowField field{flow.data, flow.stride, flow.width, flow.height};
  for (int y = y_begin; y < y_end; ++y)
    kernels::projection_contrast_row(field, y, distance, kMinFlowForDirection, contrast.row(y));
}

void fuse_amplitudes(ImageView<const float> amplitude_a, ImageView<const float> contrast_a,
                     ImageView<const float> amplitude_b, ImageView<const float> contrast_b,
                     ImageView<float> fused) {
  fuse_amplitude_rows(amplitude_a, contrast_a, amplitude_b, contrast_b, 0, fused.height, fused);
}

void fuse_amplitude_rows(ImageView<const float> amplitude_a, ImageView<const float> contrast_a,
                         ImageView<const float> amplitude_b, ImageView<const float> contrast_b,
                         int y_begin, int y_end, ImageView<float> fused) {
  assert(contrast_a.same_size(amplitude_a) && amplitude_b.same_size(amplitude_a) &&
         contrast_b.same_size(amplitude_a) && fused.same_size(amplitude_a));
  for (int y = y_begin; y < y_end; ++y) {
    const float* ma = amplitude_a.row(y);
    const float* ca = contrast_a.row(y);
    const float* mb = amplitude_b.row(y);
    const float* cb = contrast_b.row(y);
    float* out = fused.row(y);
    for (int x = 0; x < fused.width; ++x) out[x] = ca[x] > cb[x] ? ma[x] : mb[x];
  }
}

void compose_flow(ImageView<const float> near, ImageView<const float> onward,
                  ImageView<float> composed) {
  assert(near.channels == 2 && onward.channels == 2 && composed.channels == 2 &&
         onward.same_size(near) && composed.same_size(near));
  const int w = near.width, h = near.height;
  const float x_max = static_cast<float>(w - 1), y_max = static_cast<float>(h - 1);
  for (int y = 0; y < h; ++y) {
    const float* n = near.row(y);
    float* c = composed.row(y);
    for (int x = 0; x < w; ++x) {
      // Clamped first, so that past the edge the border's value is taken (and a NaN goes to 0).
      float fx = static_cast<float>(x) + n[2 * x];
      float fy = static_cast<float>(y) + n[2 * x + 1];
      fx = fx >= 0.0f ? (fx <= x_max ? fx : x_max) : 0.0f;
      fy = fy >= 0.0f ? (fy <= y_max ? fy : y_max) : 0.0f;
      const int x0 = static_cast<int>(fx), y0 = static_cast<int>(fy);
      const int x1 = std::min(x0 + 1, w - 1), y1 = std::min(y0 + 1, h - 1);
      const float ax = fx - static_cast<float>(x0), ay = fy - static_cast<float>(y0);
      const float* top = onward.row(y0);
      const float* bottom = onward.row(y1);
      for (int k = 0; k < 2; ++k) {
        const float upper = top[2 * x0 + k] + ax * (top[2 * x1 + k] - top[2 * x0 + k]);
        const float lower = bottom[2 * x0 + k] + ax * (bottom[2 * x1 + k] - bottom[2 * x0 + k]);
        c[2 * x + k] = n[2 * x + k] + upper + ay * (lower - upper);
      }
    }
  }
}

void invert_flow(ImageView<const float> forward, FlowInversionScratch& scratch,
                 ImageView<float> backward) {
  assert(forward.channels == 2 && backward.channels == 2 && backward.same_size(forward));
  const int w = forward.width;
  const int h = forward.height;
  scratch.speed.resize(w, h);
  scratch.column.resize(static_cast<std::size_t>(w));
  scratch.row.resize(static_cast<std::size_t>(w));
  scratch.row_speed.resize(static_cast<std::size_t>(w));
  const ImageView<float> speed = scratch.speed.view();
  // speed holds the squared speed of the source that landed on each pixel, -1 where none did.
  for (int y = 0; y < h; ++y) std::fill(speed.row(y), speed.row(y) + w, -1.0f);
  const kernels::FlowField field{forward.data, forward.stride, w, h};
  std::int32_t* column = scratch.column.data();
  std::int32_t* row = scratch.row.data();
  float* row_speed = scratch.row_speed.data();
  float discard[3];
  for (int y = 0; y < h; ++y) {
    // Where the row lands, vectorised; the writes stay in order, so of equally fast sources the
    // first one wins.
    kernels::flow_targets_row(field, y, column, row, row_speed);
    const float* f = forward.row(y);
    for (int x = 0; x < w; ++x) {
      const int qx = column[x];
      if (qx < 0) continue;
      const int qy = row[x];
      const float s = row_speed[x];
      float* best = speed.row(qy) + qx;
      float* b = backward.row(qy) + 2 * qx;
      // A loser writes to `discard` instead of branching: whether a source wins is as good as
      // random where a surface's sub-pixel motion makes pixels collide.
      const bool wins = s > *best;
      best = wins ? best : discard;
      b = wins ? b : discard + 1;
      best[0] = s;
      b[0] = -f[2 * x];
      b[1] = -f[2 * x + 1];
    }
  }
  for (int y = 0; y < h; ++y) {
    const float* s = speed.row(y);
    float* b = backward.row(y);
    int x = 0;
    while (x < w) {
      if (s[x] >= 0.0f) {
        ++x;
        continue;
      }
      const int start = x;
      while (x < w && s[x] < 0.0f) ++x;
      const bool has_left = start > 0;
      const bool has_right = x < w;
      float u = 0.0f, v = 0.0f;
      if (has_left || has_right) {
        const int from = !has_right || (has_left && s[start - 1] <= s[x]) ? start - 1 : x;
        u = b[2 * from];
        v = b[2 * from + 1];
      }
      for (int i = start; i < x; ++i) {
        b[2 * i] = u;
        b[2 * i + 1] = v;
      }
    }
  }
}

float normalise_by_max(ImageView<float> values, float floor) {
  const float divisor = std::max(largest_value(values, 0, values.height), floor);
  if (divisor < kLeastFlowDivisor) return 0.0f;
  divide_rows(values, divisor, 0, values.height);
  return divisor;
}

float largest_value(ImageView<const float> values, int y_begin, int y_end) {
  float largest = 0.0f;
  for (int y = y_begin; y < y_end; ++y) {
    const float* r = values.row(y);
    for (int x = 0; x < values.width; ++x) largest = std::max(largest, r[x]);
  }
  return largest;
}

void divide_rows(ImageView<float> values, float divisor, int y_begin, int y_end) {
  const float inv = 1.0f / divisor;
  for (int y = y_begin; y < y_end; ++y) {
    float* r = values.row(y);
    for (int x = 0; x < values.width; ++x) r[x] = std::min(r[x] * inv, 1.0f);
  }
}

}  // namespace dco::contour
