#pragma once

#include <cstdint>
#include <vector>

#include "dco/core/image.hpp"
#include "dco/kernels/boundary_pixel.hpp"
#include "dco/pipeline/stereo/stereo_params.hpp"

namespace dco::pipeline {
class RowTeam;
}

namespace dco::stereo {

// The rule of the boundary refinement (kernels/boundary_pixel.hpp) for these parameters: the
// window radius, the ratio in 1/256 and the support-weight table.
kernels::pixel::BoundaryRule boundary_rule(const StereoParams& params);

// Whether the refinement runs: the stage matches below the input resolution and a window is set.
bool refines_boundaries(const StereoParams& params, int scale);

// Re-decides the side of every input pixel next to a depth edge of the half-size map (and of
// pixels without a value within the rule's hole reach of one), in place on `disparity` (input
// size, input px, +inf = none). `sparse` is the internal map (internal px), `left` and `right`
// the grey input images; the sides found around each internal pixel are kept between frames so
// that a frame of the same geometry allocates nothing.
class BoundaryRefiner {
 public:
  // With a team, its threads refine blocks of the output's rows (each row on its own: the same
  // result).
  void apply(ImageView<const float> sparse, ImageView<const std::uint8_t> left,
             ImageView<const std::uint8_t> right, int scale,
             const kernels::pixel::BoundaryRule& rule, ImageView<float> disparity,
             pipeline::RowTeam* team = nullptr);

 private:
  // The sides around every internal pixel: within kBoundaryReach (far_, near_) and, when the
  // rule searches holes along the row, within its hole reach (hole_far_, hole_near_).
  void side_ranges(ImageView<const float> sparse, int hole_reach);
  // One row's minimum (far) and maximum (near, "none" left out) over +-reach columns, and over
  // +-narrow_reach columns too where narrow_far is not null (narrow_reach <= reach). The block
  // buffers must hold w + 2 reach values (side_ranges sizes them).
  void row_windows(const float* v, int w, int reach, int narrow_reach, float* far, float* near,
                   float* narrow_far, float* narrow_near);

  Image<float> row_far_, row_near_, far_, near_;
  Image<float> row_hole_far_, row_hole_near_, hole_far_, hole_near_;
  std::vector<float> lo_, hi_, lo_next_, hi_next_;  // a row's blocks, padded
  // Per thread of the team: the internal columns at a depth edge, of one row.
  std::vector<std::vector<std::uint8_t>> edges_;
};

}  // namespace dco::stereo
