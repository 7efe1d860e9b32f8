#include "dco/pipeline/stereo/boundary_refinement.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "dco/kernels/boundary_kernels.hpp"
#include "dco/pipeline/row_team.hpp"

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

// edge[x] = 1 where the narrow or the wide sides of internal pixel x span a depth edge
// (px::spans_depth_edge of either), else 0.
void edge_columns(const float* __restrict far, const float* __restrict near,
                  const float* __restrict wide_far, const float* __restrict wide_near, int n,
                  std::uint8_t* __restrict edge) {
  for (int x = 0; x < n; ++x)
    edge[x] = static_cast<std::uint8_t>((near[x] - far[x] > px::kBoundaryMinStep) |
                                        (wide_near[x] - wide_far[x] > px::kBoundaryMinStep));
}

}  // namespace

void BoundaryRefiner::side_row(ImageView<const float> sparse, int iy, int hole_reach, RowSides& s) {
  const int w = sparse.width, h = sparse.height;
  const bool holes = hole_reach > px::kBoundaryReach;
  const int widest = holes ? hole_reach : px::kBoundaryReach;
  // Across the rows first (kBoundaryReach each way), then along the row, into a row padded by
  // the widest reach with "none"; min and max are exact, so this gives side_range's values.
  std::array<const float*, 2 * px::kBoundaryReach + 1> rows{};
  const int top = std::max(0, iy - px::kBoundaryReach);
  const int count = std::min(h - 1, iy + px::kBoundaryReach) - top + 1;
  for (int k = 0; k < count; ++k) rows[static_cast<std::size_t>(k)] = sparse.row(top + k);
  float* lo = s.lo.data() + widest;
  float* hi = s.hi.data() + widest;
  kernels::boundary_column_sides(rows.data(), count, w, lo, hi);
  if (holes)
    kernels::boundary_row_sides(lo, hi, w, hole_reach, px::kBoundaryReach, s.wide_far.data(),
                                s.wide_near.data(), s.far.data(), s.near.data());
  else
    kernels::boundary_row_sides(lo, hi, w, px::kBoundaryReach, px::kBoundaryReach, s.far.data(),
                                s.near.data(), nullptr, nullptr);
  const float* wide_far = holes ? s.wide_far.data() : s.far.data();
  const float* wide_near = holes ? s.wide_near.data() : s.near.data();
  edge_columns(s.far.data(), s.near.data(), wide_far, wide_near, w, s.edge.data());
}

void BoundaryRefiner::apply(ImageView<const float> sparse, ImageView<const std::uint8_t> left,
                            ImageView<const std::uint8_t> right, int scale,
                            const px::BoundaryRule& rule, ImageView<float> disparity,
                            pipeline::RowTeam* team) {
  const int w = sparse.width, h = sparse.height;
  const bool holes = rule.hole_reach > px::kBoundaryReach;
  const int widest = holes ? rule.hole_reach : px::kBoundaryReach;
  const auto s = static_cast<float>(scale);
  const px::GreyPair im{left.data, right.data, left.stride, right.stride, left.width, left.height};
  const int parts = team != nullptr ? team->threads() : 1;
  if (sides_.size() < static_cast<std::size_t>(parts))
    sides_.resize(static_cast<std::size_t>(parts));
  const float none = px::infinity();
  for (int part = 0; part < parts; ++part) {
    RowSides& r = sides_[static_cast<std::size_t>(part)];
    const auto padded = static_cast<std::size_t>(w + 2 * widest);
    r.lo.assign(padded, none);
    r.hi.assign(padded, -none);
    for (std::vector<float>* row : {&r.far, &r.near, &r.wide_far, &r.wide_near})
      row->resize(static_cast<std::size_t>(w));
    // Eight zero bytes past the row, for the scan's words.
    r.edge.assign(static_cast<std::size_t>(w) + 8, 0);
  }
  const auto refine_rows = [&](int part, int y_begin, int y_end) {
    kernels::BoundaryWindow window;  // the side costs of one pixel share its support weights
    RowSides& sides = sides_[static_cast<std::size_t>(part)];
    // Most internal pixels are away from any edge: the sides and the columns at an edge are
    // found once per internal row, then a word of eight columns at a time skipped where none is.
    const std::uint8_t* edge = sides.edge.data();
    int sides_row = -1;
    for (int y = y_begin; y < y_end; ++y) {
      const int iy = std::min(y / scale, h - 1);
      if (iy != sides_row) {
        side_row(sparse, iy, rule.hole_reach, sides);
        sides_row = iy;
      }
      const float* far = sides.far.data();
      const float* near = sides.near.data();
      const float* hole_far = holes ? sides.wide_far.data() : far;
      const float* hole_near = holes ? sides.wide_near.data() : near;
      float* out = disparity.row(y);
      // Input column x belongs to internal column min(x / scale, w - 1).
      for (int ix = 0; ix < w; ++ix) {
        if (ix % 8 == 0) {
          std::uint64_t word;
          std::memcpy(&word, edge + ix, sizeof word);
          if (word == 0) {
            ix += 7;
            continue;
          }
        }
        if (edge[ix] == 0) continue;
        const px::SideRange narrow{far[ix], near[ix]}, wide{hole_far[ix], hole_near[ix]};
        const int x_end = ix + 1 == w ? disparity.width : (ix + 1) * scale;
        for (int x = ix * scale; x < x_end; ++x) {
          const px::BoundarySides sides_of_x = px::boundary_sides(out[x], narrow, wide, rule);
          if (!sides_of_x.refine) continue;
          kernels::boundary_window(im, x, y, rule, window);
          out[x] = px::refined_boundary_choice(
              out[x], sides_of_x.range, s, sides_of_x.keep,
              [&](int d) { return kernels::boundary_side_cost(im, window, d, rule); });
        }
      }
    }
  };
  if (team != nullptr)
    team->run(disparity.height, refine_rows);
  else
    refine_rows(0, 0, disparity.height);
}

}  // namespace dco::stereo
