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
  rule.hole_reach = params.boundary_hole_reach;
  rule.hole_keep = static_cast<std::uint32_t>(std::lround(params.boundary_hole_ratio * 256.0));
  for (int i = 0; i < 256; ++i)
    rule.weight[i] = static_cast<std::uint16_t>(
        std::lround(px::kBoundaryWeightOne * std::exp(-i / px::kBoundaryGreyScale)));
  return rule;
}

bool refines_boundaries(const StereoParams& params, int scale) {
  return scale > 1 && params.boundary_radius > 0;
}

namespace {

// side_range over a whole map, separably: the window's minimum (+inf, "none", never wins it) and
// maximum ("none" counted as -inf) over rows first (reach_x columns each way), then over columns
// (kBoundaryReach rows each way). Min and max are exact, so this gives side_range's values.
void side_ranges(ImageView<const float> sparse, int reach_x, Image<float>& row_far,
                 Image<float>& row_near, Image<float>& far, Image<float>& near) {
  const int w = sparse.width, h = sparse.height;
  const float none = px::infinity();
  row_far.resize(w, h);
  row_near.resize(w, h);
  far.resize(w, h);
  near.resize(w, h);
  // Rows: each offset of the window in turn over the whole row, so that the loop over x
  // vectorises whatever the reach.
  for (int y = 0; y < h; ++y) {
    const float* v = sparse.row(y);
    float* rf = row_far.row(y);
    float* rn = row_near.row(y);
    std::fill(rf, rf + w, none);
    std::fill(rn, rn + w, -none);
    for (int k = -reach_x; k <= reach_x; ++k) {
      const int x0 = std::max(0, -k), x1 = std::min(w, w - k);
      const float* vk = v + k;
      for (int x = x0; x < x1; ++x) {
        const float e = vk[x];
        const float n = e < none ? e : -none;  // "none" never counts as the near side
        rf[x] = e < rf[x] ? e : rf[x];
        rn[x] = n > rn[x] ? n : rn[x];
      }
    }
  }
  for (int y = 0; y < h; ++y) {
    float* f = far.row(y);
    float* n = near.row(y);
    std::fill(f, f + w, none);
    std::fill(n, n + w, -none);
    for (int yy = std::max(0, y - px::kBoundaryReach);
         yy <= std::min(h - 1, y + px::kBoundaryReach); ++yy) {
      const float* rf = row_far.row(yy);
      const float* rn = row_near.row(yy);
      for (int x = 0; x < w; ++x) {
        f[x] = std::min(f[x], rf[x]);
        n[x] = std::max(n[x], rn[x]);
      }
    }
  }
}

}  // namespace

void BoundaryRefiner::apply(ImageView<const float> sparse, ImageView<const std::uint8_t> left,
                            ImageView<const std::uint8_t> right, int scale,
                            const px::BoundaryRule& rule, ImageView<float> disparity) {
  const int w = sparse.width, h = sparse.height;
  side_ranges(sparse, px::kBoundaryReach, row_far_, row_near_, far_, near_);
  const bool holes = rule.hole_reach > px::kBoundaryReach;
  if (holes) side_ranges(sparse, rule.hole_reach, row_far_, row_near_, hole_far_, hole_near_);
  const auto s = static_cast<float>(scale);
  const px::GreyPair im{left.data, right.data, left.stride, right.stride, left.width, left.height};
  kernels::BoundaryWindow window;  // the side costs of one pixel share its support weights
  for (int y = 0; y < disparity.height; ++y) {
    const int iy = std::min(y / scale, h - 1);
    const float* far = far_.row(iy);
    const float* near = near_.row(iy);
    const float* hole_far = holes ? hole_far_.row(iy) : far;
    const float* hole_near = holes ? hole_near_.row(iy) : near;
    float* out = disparity.row(y);
    // Most pixels are away from any edge: skip them an internal pixel at a time. Input column x
    // belongs to internal column min(x / scale, w - 1).
    for (int ix = 0; ix < w; ++ix) {
      const px::SideRange narrow{far[ix], near[ix]}, wide{hole_far[ix], hole_near[ix]};
      if (!px::spans_depth_edge(narrow) && !px::spans_depth_edge(wide)) continue;
      const int x_end = ix + 1 == w ? disparity.width : (ix + 1) * scale;
      for (int x = ix * scale; x < x_end; ++x) {
        const px::BoundarySides sides = px::boundary_sides(out[x], narrow, wide, rule);
        if (!sides.refine) continue;
        kernels::boundary_window(im, x, y, rule, window);
        out[x] = px::refined_boundary_choice(out[x], sides.range, s, sides.keep, [&](int d) {
          return kernels::boundary_side_cost(im, window, d, rule);
        });
      }
    }
  }
}

}  // namespace dco::stereo
