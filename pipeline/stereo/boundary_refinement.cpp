#include "dco/pipeline/stereo/boundary_refinement.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "dco/kernels/boundary_kernels.hpp"
#include "dco/kernels/filter_kernels.hpp"
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

// out = the elementwise least (greatest) of a and b, as `b < a ? b : a` (`b > a ? b : a`).
void min_of_pairs(const float* a, const float* b, int n, float* out) {
  const float* rows[2] = {a, b};
  kernels::min_of_rows(rows, 2, n, out);
}
void max_of_pairs(const float* a, const float* b, int n, float* out) {
  const float* rows[2] = {a, b};
  kernels::max_of_rows(rows, 2, n, out);
}

// edge[x] = 1 where the narrow or the wide sides of internal pixel x span a depth edge
// (px::spans_depth_edge of either), else 0.
void edge_columns(const float* __restrict far, const float* __restrict near,
                  const float* __restrict wide_far, const float* __restrict wide_near, int n,
                  std::uint8_t* __restrict edge) {
  for (int x = 0; x < n; ++x)
    edge[x] = static_cast<std::uint8_t>((near[x] - far[x] > px::kBoundaryMinStep) |
                                        (wide_near[x] - wide_far[x] > px::kBoundaryMinStep));
}

// The least level k with 2^(k+1) > 2 reach + 1: a window of 2 reach + 1 is two blocks of 2^k.
int block_level(int reach) {
  int k = 0;
  while ((2 << k) <= 2 * reach + 1) ++k;
  return k;
}

}  // namespace

void BoundaryRefiner::row_windows(const float* v, int w, int reach, int narrow_reach, float* far,
                                  float* near, float* narrow_far, float* narrow_near) {
  // The row padded by `reach` on each side ("none" outside: +inf for the far side, -inf for the
  // near side, where "none" never counts). Block level k holds at i the minimum (maximum) of the
  // 2^k padded values from i on, built by doubling; the window of input column x is the two
  // blocks that start at x - r and end at x + r (their overlap does not change a min or max).
  const float none = px::infinity();
  const int padded = w + 2 * reach;
  float* lo = lo_.data();
  float* hi = hi_.data();
  std::fill(lo, lo + reach, none);
  std::fill(hi, hi + reach, -none);
  for (int x = 0; x < w; ++x) {
    lo[reach + x] = v[x];
    hi[reach + x] = v[x] < none ? v[x] : -none;
  }
  std::fill(lo + reach + w, lo + padded, none);
  std::fill(hi + reach + w, hi + padded, -none);
  const auto window = [&](int r, int k, float* out_far, float* out_near) {
    const int second = 2 * r + 1 - (1 << k);  // offset of the block that ends at x + r
    min_of_pairs(lo + reach - r, lo + reach - r + second, w, out_far);
    max_of_pairs(hi + reach - r, hi + reach - r + second, w, out_near);
  };
  const int narrow_level = narrow_far != nullptr ? block_level(narrow_reach) : -1;
  const int level = block_level(reach);
  for (int k = 0;; ++k) {
    if (k == narrow_level) window(narrow_reach, k, narrow_far, narrow_near);
    if (k == level) {
      window(reach, k, far, near);
      return;
    }
    const int step = 1 << k, count = padded - 2 * step + 1;  // blocks of 2^(k+1) that fit
    min_of_pairs(lo, lo + step, count, lo_next_.data());
    max_of_pairs(hi, hi + step, count, hi_next_.data());
    lo_.swap(lo_next_);
    hi_.swap(hi_next_);
    lo = lo_.data();
    hi = hi_.data();
  }
}

void BoundaryRefiner::side_ranges(ImageView<const float> sparse, int hole_reach) {
  const int w = sparse.width, h = sparse.height;
  const bool holes = hole_reach > px::kBoundaryReach;
  for (Image<float>* img : {&row_far_, &row_near_, &far_, &near_}) img->resize(w, h);
  if (holes)
    for (Image<float>* img : {&row_hole_far_, &row_hole_near_, &hole_far_, &hole_near_})
      img->resize(w, h);
  // A row padded by the widest reach, for row_windows' blocks.
  const int widest = holes ? hole_reach : px::kBoundaryReach;
  for (std::vector<float>* b : {&lo_, &hi_, &lo_next_, &hi_next_})
    b->resize(static_cast<std::size_t>(w + 2 * widest));
  // Rows first (reach_x columns each way), then columns (kBoundaryReach rows each way): min and
  // max are exact, so this gives side_range's values.
  for (int y = 0; y < h; ++y) {
    if (holes)
      row_windows(sparse.row(y), w, hole_reach, px::kBoundaryReach, row_hole_far_.row(y),
                  row_hole_near_.row(y), row_far_.row(y), row_near_.row(y));
    else
      row_windows(sparse.row(y), w, px::kBoundaryReach, 0, row_far_.row(y), row_near_.row(y),
                  nullptr, nullptr);
  }
  const auto columns = [&](const Image<float>& row_far, const Image<float>& row_near,
                           Image<float>& far, Image<float>& near) {
    std::array<const float*, 2 * px::kBoundaryReach + 1> fars{}, nears{};
    for (int y = 0; y < h; ++y) {
      const int top = std::max(0, y - px::kBoundaryReach);
      const int bottom = std::min(h - 1, y + px::kBoundaryReach);
      const int count = bottom - top + 1;
      for (int k = 0; k < count; ++k) {
        fars[static_cast<std::size_t>(k)] = row_far.row(top + k);
        nears[static_cast<std::size_t>(k)] = row_near.row(top + k);
      }
      kernels::min_of_rows(fars.data(), count, w, far.row(y));
      kernels::max_of_rows(nears.data(), count, w, near.row(y));
    }
  };
  columns(row_far_, row_near_, far_, near_);
  if (holes) columns(row_hole_far_, row_hole_near_, hole_far_, hole_near_);
}

void BoundaryRefiner::apply(ImageView<const float> sparse, ImageView<const std::uint8_t> left,
                            ImageView<const std::uint8_t> right, int scale,
                            const px::BoundaryRule& rule, ImageView<float> disparity,
                            pipeline::RowTeam* team) {
  const int w = sparse.width, h = sparse.height;
  const bool holes = rule.hole_reach > px::kBoundaryReach;
  side_ranges(sparse, rule.hole_reach);
  const auto s = static_cast<float>(scale);
  const px::GreyPair im{left.data, right.data, left.stride, right.stride, left.width, left.height};
  const int parts = team != nullptr ? team->threads() : 1;
  if (edges_.size() < static_cast<std::size_t>(parts))
    edges_.resize(static_cast<std::size_t>(parts));
  const auto refine_rows = [&](int part, int y_begin, int y_end) {
    kernels::BoundaryWindow window;  // the side costs of one pixel share its support weights
    // Most internal pixels are away from any edge: the ones that are, once per internal row,
    // then a word of eight at a time skipped where none is.
    std::vector<std::uint8_t>& edge = edges_[static_cast<std::size_t>(part)];
    edge.resize(static_cast<std::size_t>(w) + 8);
    std::fill(edge.begin() + w, edge.end(), std::uint8_t{0});
    int edge_row = -1;
    for (int y = y_begin; y < y_end; ++y) {
      const int iy = std::min(y / scale, h - 1);
      const float* far = far_.row(iy);
      const float* near = near_.row(iy);
      const float* hole_far = holes ? hole_far_.row(iy) : far;
      const float* hole_near = holes ? hole_near_.row(iy) : near;
      if (iy != edge_row) {
        edge_columns(far, near, hole_far, hole_near, w, edge.data());
        edge_row = iy;
      }
      float* out = disparity.row(y);
      // Input column x belongs to internal column min(x / scale, w - 1).
      for (int ix = 0; ix < w; ++ix) {
        if (ix % 8 == 0) {
          std::uint64_t word;
          std::memcpy(&word, edge.data() + ix, sizeof word);
          if (word == 0) {
            ix += 7;
            continue;
          }
        }
        if (edge[static_cast<std::size_t>(ix)] == 0) continue;
        const px::SideRange narrow{far[ix], near[ix]}, wide{hole_far[ix], hole_near[ix]};
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
  };
  if (team != nullptr)
    team->run(disparity.height, refine_rows);
  else
    refine_rows(0, 0, disparity.height);
}

}  // namespace dco::stereo
