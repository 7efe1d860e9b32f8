#pragma once

// Per-pixel math of the boundary refinement, shared by the CPU stereo stage and the CUDA passes
// (gpu/). When the stereo stage matches at half size, every value covers a 2x2 block of the
// input and a depth edge can only fall between blocks; around such edges this step decides, at
// the input resolution, which side of the edge each input pixel belongs to. The candidate values
// come from the half-size map (the surfaces on both sides); only the choice between them is made
// at full size, from a grey-level absolute difference summed over a window weighted by grey
// similarity to the centre pixel (adaptive support weights), so a window on a thin finger is not
// dominated by the background around it. Integer sums only, so CPU and GPU agree bit for bit.

#include <cstdint>

#include "dco/kernels/host_device.hpp"
#include "dco/kernels/stereo_pixel.hpp"

namespace dco::kernels::pixel {

inline constexpr int kBoundaryReach = 2;            // internal px searched for the two sides
inline constexpr float kBoundaryMinStep = 1.0f;     // internal px between the sides: a depth edge
inline constexpr int kBoundaryCap = 30;             // truncation of the grey-level difference
inline constexpr int kBoundaryWeightOne = 1024;     // support weight of an equal grey level
inline constexpr double kBoundaryGreyScale = 10.0;  // weight = exp(-|grey step| / this)

struct BoundaryRule {
  int radius = 0;          // window half size, input px (0 = off)
  std::uint32_t keep = 0;  // the winning side's cost must be at most keep / 256 of the other's
  // A pixel without a value whose internal pixel has no depth edge within kBoundaryReach looks
  // for the sides up to hole_reach internal px along its row (kBoundaryReach across it), and
  // then a side must win by hole_keep / 256. hole_reach <= kBoundaryReach: no such search.
  int hole_reach = 0;
  std::uint32_t hole_keep = 0;
  std::uint16_t weight[256] = {};  // support weight per grey-level step to the centre pixel
};

// Smallest and largest value of the sparse map (internal px, +inf = none) within reach_x columns
// and kBoundaryReach rows of internal pixel (x, y): the far and the near surface when the pixel
// sits at a depth edge.
struct SideRange {
  float far, near;
};

DCO_HD inline bool spans_depth_edge(SideRange r) {
  return r.near - r.far > kBoundaryMinStep;
}

DCO_HD inline SideRange side_range(const float* sparse, std::ptrdiff_t stride, int width,
                                   int height, int x, int y, int reach_x = kBoundaryReach) {
  const float none = infinity();
  SideRange r{none, -none};
  for (int yy = max_of(0, y - kBoundaryReach); yy <= min_of(height - 1, y + kBoundaryReach); ++yy)
    for (int xx = max_of(0, x - reach_x); xx <= min_of(width - 1, x + reach_x); ++xx) {
      const float v = sparse[yy * stride + xx];
      if (!(v < none)) continue;
      r.far = v < r.far ? v : r.far;
      r.near = v > r.near ? v : r.near;
    }
  return r;
}

// The grey input images at full size.
struct GreyPair {
  const std::uint8_t* left;
  const std::uint8_t* right;
  std::ptrdiff_t left_stride, right_stride;  // elements
  int width, height;
};

// Weighted, truncated grey-level difference of the window around input pixel (x, y) against the
// right image shifted by disparity d; columns whose match falls outside the image cost the cap.
DCO_HD inline std::uint32_t side_cost(const GreyPair& im, int x, int y, int d,
                                      const BoundaryRule& rule) {
  const int centre = im.left[y * im.left_stride + x];
  std::uint32_t sum = 0;
  for (int qy = max_of(0, y - rule.radius); qy <= min_of(im.height - 1, y + rule.radius); ++qy) {
    const std::uint8_t* l = im.left + qy * im.left_stride;
    const std::uint8_t* r = im.right + qy * im.right_stride;
    for (int qx = max_of(0, x - rule.radius); qx <= min_of(im.width - 1, x + rule.radius); ++qx) {
      const int grey = l[qx];
      const int xr = qx - d;
      const int e = xr >= 0 ? min_of(abs_of(grey - r[xr]), kBoundaryCap) : kBoundaryCap;
      sum += static_cast<std::uint32_t>(rule.weight[abs_of(grey - centre)]) *
             static_cast<std::uint32_t>(e);
    }
  }
  return sum;
}

// The sides an input pixel is refined against and the ratio a side must win by: those within
// kBoundaryReach of its internal pixel (`narrow`) when they span a depth edge; else, for a pixel
// without a value, those within the rule's hole_reach along the row (`wide`) under hole_keep.
// Such holes are mostly blocks of a thin object's rim, or of the background beside it, that the
// checks removed; the stricter ratio because the wider search finds more pairs of sides that
// are not the pixel's. refine == false: the pixel is left as it is.
struct BoundarySides {
  SideRange range;
  std::uint32_t keep;
  bool refine;
};

DCO_HD inline BoundarySides boundary_sides(float own, SideRange narrow, SideRange wide,
                                           const BoundaryRule& rule) {
  if (spans_depth_edge(narrow)) return {narrow, rule.keep, true};
  const bool hole = !(own < infinity());
  if (hole && rule.hole_reach > kBoundaryReach && spans_depth_edge(wide))
    return {wide, rule.hole_keep, true};
  return {narrow, rule.keep, false};
}

// The refined value of an input pixel: `own` is its value from the half-size map (input px,
// +inf = none), `range` the sides around its internal pixel, `scale` the internal downscale,
// `keep` the ratio in 1/256, and cost(d) its side_cost at disparity d. Away from a depth edge the
// value is kept. At one, the far side, the near side and the pixel's own value compete; if a
// side wins, it must beat the other side by the ratio, else the pixel is left without a value
// for the densifier to fill.
template <class Cost>
DCO_HD inline float refined_boundary_choice(float own, SideRange range, float scale,
                                            std::uint32_t keep, const Cost& cost) {
  if (!spans_depth_edge(range)) return own;
  const float none = infinity();
  const float far = scale * range.far, near = scale * range.near;
  const int d_far = static_cast<int>(far + 0.5f), d_near = static_cast<int>(near + 0.5f);
  const std::uint32_t cost_far = cost(d_far);
  const std::uint32_t cost_near = cost(d_near);
  if (own < none) {
    // The pixel's own value passed the checks: it stays unless a side matches strictly better.
    // A side at the same whole disparity costs the same, and then the own value wins.
    const int d_own = static_cast<int>(own + 0.5f);
    const std::uint32_t cost_own = d_own == d_far    ? cost_far
                                   : d_own == d_near ? cost_near
                                                     : cost(d_own);
    if (cost_own <= cost_far && cost_own <= cost_near) return own;
  }
  const bool far_wins = cost_far <= cost_near;
  const std::uint32_t best = far_wins ? cost_far : cost_near;
  const std::uint32_t other = far_wins ? cost_near : cost_far;
  const bool decided = best < other && static_cast<std::uint64_t>(best) * 256u <=
                                           static_cast<std::uint64_t>(keep) * other;
  return decided ? (far_wins ? far : near) : none;
}

// The refined value of input pixel (x, y) from the sides around its internal pixel (`narrow`
// and `wide`, see boundary_sides), with its side costs computed here.
DCO_HD inline float refined_boundary_value(const GreyPair& im, int x, int y, float own,
                                           SideRange narrow, SideRange wide, float scale,
                                           const BoundaryRule& rule) {
  const BoundarySides sides = boundary_sides(own, narrow, wide, rule);
  if (!sides.refine) return own;
  return refined_boundary_choice(own, sides.range, scale, sides.keep,
                                 [&](int d) { return side_cost(im, x, y, d, rule); });
}

}  // namespace dco::kernels::pixel
