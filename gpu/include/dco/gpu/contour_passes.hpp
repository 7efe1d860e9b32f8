#pragma once

// The image side of the contour stage as data-parallel passes over tightly packed buffers (see
// stereo_passes.hpp): the stereo cue and its box filter, the 5x5 Gaussian, the Sobel gradient and
// the gated Canny classification. The per-pixel math is dco::kernels::pixel (contour_pixel.hpp),
// shared with the CPU functions, in the same order, so the results are equal bit for bit.

#include <cstdint>

#include "dco/gpu/stereo_passes.hpp"
#include "dco/kernels/contour_pixel.hpp"

namespace dco::gpu::passes {

struct GaussianVertical {
  const std::uint8_t* in;
  float* out;
  int width, height;
  float taps[5];
  DCO_HD void operator()(int x, int y) const {
    const auto v = [this, x](int row) {
      return static_cast<float>(in[at(x, px::clamp_to(row, 0, height - 1), width)]);
    };
    out[at(x, y, width)] =
        px::gaussian5_vertical(v(y - 2), v(y - 1), v(y), v(y + 1), v(y + 2), taps);
  }
};

struct GaussianHorizontal {
  const float* in;
  float* out;
  int width;
  float taps[5];
  DCO_HD void operator()(int x, int y) const {
    const float* t = taps;
    out[at(x, y, width)] =
        px::clamped_tap_sum(in + at(0, y, width), width, x, 2, [t](int k) { return t[k]; });
  }
};

// The mean box filter of odd `size`: columns, then rows.
struct BoxVertical {
  const float* in;
  float* out;
  int width, height, size;
  float inv;
  DCO_HD void operator()(int x, int y) const {
    out[at(x, y, width)] = px::box_column_mean(in + x, width, height, y, size, inv);
  }
};

struct BoxHorizontal {
  const float* in;
  float* out;
  int width, size;
  float inv;
  DCO_HD void operator()(int x, int y) const {
    const float w = inv;
    out[at(x, y, width)] =
        px::clamped_tap_sum(in + at(0, y, width), width, x, size / 2, [w](int) { return w; });
  }
};

struct JumpStrength {
  const float* disparity;
  float* out;
  int width, height;
  float inv;
  DCO_HD void operator()(int x, int y) const {
    const float* mid = disparity + at(0, y, width);
    const float* up = disparity + at(0, px::max_of(y - 1, 0), width);
    const float* down = disparity + at(0, px::min_of(y + 1, height - 1), width);
    out[at(x, y, width)] = px::jump_strength(
        mid[x], mid[px::max_of(x - 1, 0)], mid[px::min_of(x + 1, width - 1)], up[x], down[x], inv);
  }
};

struct MaxInto {
  const float* in;
  float* inout;
  int width;
  DCO_HD void operator()(int x, int y) const {
    const float s = in[at(x, y, width)];
    float& d = inout[at(x, y, width)];
    d = s > d ? s : d;
  }
};

struct FillFloat {
  float* out;
  int width;
  float value;
  DCO_HD void operator()(int x, int y) const { out[at(x, y, width)] = value; }
};

// Magnitude / norm and the quantised direction of the Sobel gradient, borders replicated.
struct Sobel {
  const float* smoothed;
  float* magnitude;
  std::uint8_t* direction;
  int width, height;
  float inv_norm;
  DCO_HD void operator()(int x, int y) const {
    const float* mid = smoothed + at(0, y, width);
    const float* up = smoothed + at(0, px::max_of(y - 1, 0), width);
    const float* down = smoothed + at(0, px::min_of(y + 1, height - 1), width);
    const int l = px::max_of(x - 1, 0), r = px::min_of(x + 1, width - 1);
    const float gx = px::sobel_gx(up, mid, down, l, r);
    const float gy = px::sobel_gy(up, down, l, x, r);
    magnitude[at(x, y, width)] = px::gradient_magnitude(gx, gy, inv_norm);
    direction[at(x, y, width)] = px::gradient_direction(gx, gy);
  }
};

// Non-maximum suppression, the gate (internal resolution, sampled per image pixel) and the dual
// threshold; border rows and columns 0. What is left for the hysteresis, as the CPU's rows.
struct CannyClassify {
  const float* magnitude;
  const std::uint8_t* direction;
  const float* gate;
  int width, height, gate_width, gate_height;
  kernels::CannyLevels levels;
  std::uint8_t* out;
  DCO_HD void operator()(int x, int y) const {
    std::uint8_t c = kernels::kCannyNone;
    if (x > 0 && y > 0 && x < width - 1 && y < height - 1) {
      const float g = gate[at(px::gate_sample(x, width, gate_width),
                              px::gate_sample(y, height, gate_height), gate_width)];
      const float* row = magnitude + at(0, y, width);
      c = px::canny_class(row - width, row, row + width, direction[at(x, y, width)], true, g, x,
                          levels);
    }
    out[at(x, y, width)] = c;
  }
};

}  // namespace dco::gpu::passes
