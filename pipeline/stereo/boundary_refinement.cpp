#include "dco/pipeline/stereo/boundary_refinement.hpp"

#include <algorithm>
#include <cmath>

#include "dco/kernels/boundary_kernels.hpp"

namespace dco::stereo {

namespace px = kernels::pixel;

px::BoundaryRule boundary_rule(const StereoParams& params) {
  px::BoundaryRule rule;
  rule.radius = params.boundary_radius;
  rule.keep = static_cast<std::uint32_t>(std::lround(params.boundary_ratio * 256.0));
  for (int i = 0; i < 256; ++i)
    rule.weight[i] = static_cast<std::uint16_t>(
        std::lround(px::kBoundaryWeightOne * std::exp(-i / px::kBoundaryGreyScale)));
  return rule;
}

bool refines_boundaries(const StereoParams& params, int scale) {
  return scale > 1 && params.boundary_radius > 0;
}

void BoundaryRefiner::apply(ImageView<const float> sparse, ImageView<const std::uint8_t> left,
                            ImageView<const std::uint8_t> right, int scale,
                            const px::BoundaryRule& rule, ImageView<float> disparity) {
  const int w = sparse.width, h = sparse.height;
  // side_range, separably: the window's minimum (+inf, "none", never wins it) and maximum
  // ("none" counted as -inf) over rows first, then over columns. Min and max are exact, so this
  // gives side_range's values.
  const float none = px::infinity();
  row_far_.resize(w, h);
  row_near_.resize(w, h);
  far_.resize(w, h);
  near_.resize(w, h);
  constexpr int kReach = px::kBoundaryReach;
  for (int y = 0; y < h; ++y) {
    const float* v = sparse.row(y);
    float* rf = row_far_.row(y);
    float* rn = row_near_.row(y);
    const auto clamped = [&](int x) {
      float lo = none, hi = -none;
      for (int xx = std::max(0, x - kReach); xx <= std::min(w - 1, x + kReach); ++xx) {
        lo = std::min(lo, v[xx]);
        hi = std::max(hi, v[xx] < none ? v[xx] : -none);
      }
      rf[x] = lo;
      rn[x] = hi;
    };
    const int interior_end = std::max(kReach, w - kReach);
    for (int x = 0; x < std::min(kReach, w); ++x) clamped(x);
    // The interior without clamps, the window unrolled: a loop the compiler vectorises.
    for (int x = kReach; x < interior_end; ++x) {
      float lo = none, hi = -none;
      for (int k = -kReach; k <= kReach; ++k) {
        const float e = v[x + k];
        const float near = e < none ? e : -none;  // "none" never counts as the near side
        lo = e < lo ? e : lo;
        hi = near > hi ? near : hi;
      }
      rf[x] = lo;
      rn[x] = hi;
    }
    for (int x = std::max(interior_end, std::min(kReach, w)); x < w; ++x) clamped(x);
  }
  for (int y = 0; y < h; ++y) {
    float* f = far_.row(y);
    float* n = near_.row(y);
    std::fill(f, f + w, none);
    std::fill(n, n + w, -none);
    for (int yy = std::max(0, y - px::kBoundaryReach);
         yy <= std::min(h - 1, y + px::kBoundaryReach); ++yy) {
      const float* rf = row_far_.row(yy);
      const float* rn = row_near_.row(yy);
      for (int x = 0; x < w; ++x) {
        f[x] = std::min(f[x], rf[x]);
        n[x] = std::max(n[x], rn[x]);
      }
    }
  }
  const auto s = static_cast<float>(scale);
  const px::GreyPair im{left.data, right.data, left.stride, right.stride, left.width, left.height};
  kernels::BoundaryWindow window;  // the side costs of one pixel share its support weights
  for (int y = 0; y < disparity.height; ++y) {
    const int iy = std::min(y / scale, h - 1);
    const float* far = far_.row(iy);
    const float* near = near_.row(iy);
    float* out = disparity.row(y);
    // Most pixels are away from any edge: skip them an internal pixel at a time. Input column x
    // belongs to internal column min(x / scale, w - 1).
    for (int ix = 0; ix < w; ++ix) {
      if (!(near[ix] - far[ix] > px::kBoundaryMinStep)) continue;
      const int x_end = ix + 1 == w ? disparity.width : (ix + 1) * scale;
      for (int x = ix * scale; x < x_end; ++x) {
        kernels::boundary_window(im, x, y, rule, window);
        out[x] = px::refined_boundary_choice(out[x], {far[ix], near[ix]}, s, rule, [&](int d) {
          return kernels::boundary_side_cost(im, window, d, rule);
        });
      }
    }
  }
}

}  // namespace dco::stereo
