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
// the grey input images. The sides around each internal pixel are found one internal row at a
// time, as the rows are refined, in rows kept between frames so that a frame of the same
// geometry allocates nothing.
class BoundaryRefiner {
 public:
  // With a team, its threads refine blocks of the output's rows (each row on its own: the same
  // result).
  void apply(ImageView<const float> sparse, ImageView<const std::uint8_t> left,
             ImageView<const std::uint8_t> right, int scale,
             const kernels::pixel::BoundaryRule& rule, ImageView<float> disparity,
             pipeline::RowTeam* team = nullptr);

 private:
  // One thread's sides of one internal row: its columns' extremes over kBoundaryReach rows
  // (padded by the widest reach with "none"), the sides within kBoundaryReach (far, near) and,
  // when the rule searches holes along the row, within its hole reach (wide_far, wide_near), and
  // which columns sit at a depth edge.
  struct RowSides {
    std::vector<float> lo, hi, far, near, wide_far, wide_near;
    std::vector<std::uint8_t> edge;
  };
  static void side_row(ImageView<const float> sparse, int iy, int hole_reach, RowSides& s);

  std::vector<RowSides> sides_;  // per thread of the team
};

}  // namespace dco::stereo
