#pragma once

// The sparse stereo stage as data-parallel passes: each pass is a functor called once per grid
// point (x, y), with raw pointers into tightly packed buffers. A Grid (host_grid.hpp, or the CUDA
// one in gpu/src) runs them; the per-pixel math is dco::kernels::pixel, shared with the CPU path.
//
// Cost volumes hold element (x, y, k) at (y * width + x) * depth + k, so neighbouring threads
// (k fastest) touch neighbouring words. Region sums follow the CPU's order exactly (running sums
// along one axis, then differences along the arms) with uint32 wrap-around, so every sum, mean and
// decision equals the CPU's bit for bit.

#include <cstddef>
#include <cstdint>

#include "dco/kernels/boundary_pixel.hpp"
#include "dco/kernels/host_device.hpp"
#include "dco/kernels/stereo_kernels.hpp"
#include "dco/kernels/stereo_pixel.hpp"

namespace dco::gpu::passes {

namespace px = kernels::pixel;

DCO_HD inline std::size_t at(int x, int y, int width) {
  return static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
         static_cast<std::size_t>(x);
}
DCO_HD inline std::size_t at(int x, int y, int k, int width, int depth) {
  return at(x, y, width) * static_cast<std::size_t>(depth) + static_cast<std::size_t>(k);
}

// Grid (w, h) of the output: 2x2 block means of every channel.
struct DownsampleHalf {
  const std::uint8_t* in;
  int in_width;
  std::uint8_t* out;
  int out_width, channels;
  DCO_HD void operator()(int x, int y) const {
    const std::uint8_t* a = in + at(2 * x, 2 * y, in_width) * channels;
    const std::uint8_t* b = a + static_cast<std::size_t>(in_width) * channels;
    std::uint8_t* o = out + at(x, y, out_width) * channels;
    for (int c = 0; c < channels; ++c)
      o[c] = px::half_mean(a[c], a[c + channels], b[c], b[c + channels]);
  }
};

struct BgrToGrey {
  const std::uint8_t* bgr;
  std::uint8_t* grey;
  int width;
  DCO_HD void operator()(int x, int y) const {
    const std::uint8_t* p = bgr + at(x, y, width) * 3;
    grey[at(x, y, width)] = px::grey_of_bgr(p[0], p[1], p[2]);
  }
};

// kernels::pack_pixels: channel c in bits 8c..8c+7.
struct Pack {
  const std::uint8_t* in;
  std::uint32_t* out;
  int width, channels;
  DCO_HD void operator()(int x, int y) const {
    const std::uint8_t* p = in + at(x, y, width) * channels;
    std::uint32_t word = 0;
    for (int c = 0; c < channels; ++c) word |= std::uint32_t{p[c]} << (8 * c);
    out[at(x, y, width)] = word;
  }
};

struct Census {
  const std::uint8_t* grey;
  std::uint64_t* out;
  int width, height, window_w, window_h;
  DCO_HD void operator()(int x, int y) const {
    const std::uint8_t* g = grey;
    const int w = width, h = height, top = y - window_h / 2;
    const auto row = [g, w, h, top](int j) {
      return g + at(0, px::clamp_to(top + j, 0, h - 1), w);
    };
    out[at(x, y, width)] = px::census_bits(row, x, width, window_w, window_h);
  }
};

struct Arms {
  const std::uint32_t* packed;
  int width, height;
  kernels::ArmParams rule;
  std::uint8_t *left, *right, *up, *down;
  DCO_HD void operator()(int x, int y) const {
    const std::uint32_t* a = packed + at(x, y, width);
    const std::ptrdiff_t row = width;
    const std::uint32_t anchor = *a;
    const auto along = [a](std::ptrdiff_t step) {
      return [a, step](int i) { return a[step * i]; };
    };
    const std::size_t i = at(x, y, width);
    left[i] = static_cast<std::uint8_t>(
        px::arm_length(anchor, along(-1), px::min_of(rule.arm_max, x), rule));
    right[i] = static_cast<std::uint8_t>(
        px::arm_length(anchor, along(1), px::min_of(rule.arm_max, width - 1 - x), rule));
    up[i] = static_cast<std::uint8_t>(
        px::arm_length(anchor, along(-row), px::min_of(rule.arm_max, y), rule));
    down[i] = static_cast<std::uint8_t>(
        px::arm_length(anchor, along(row), px::min_of(rule.arm_max, height - 1 - y), rule));
  }
};

// The window-shape smoothing (3-tap median of the horizontal arms down the columns, of the
// vertical arms along the rows, borders repeated), or a copy; and L_min of Eq. 1.
struct SmoothArms {
  const std::uint8_t *left_in, *right_in, *up_in, *down_in;
  std::uint8_t *left, *right, *up, *down, *shortest;
  int width, height;
  bool smooth;
  DCO_HD void operator()(int x, int y) const {
    const std::size_t i = at(x, y, width);
    int l = left_in[i], r = right_in[i], u = up_in[i], d = down_in[i];
    if (smooth) {
      const std::size_t above = at(x, px::max_of(y - 1, 0), width);
      const std::size_t below = at(x, px::min_of(y + 1, height - 1), width);
      const std::size_t before = at(px::max_of(x - 1, 0), y, width);
      const std::size_t after = at(px::min_of(x + 1, width - 1), y, width);
      l = px::median3(l, left_in[above], left_in[below]);
      r = px::median3(r, right_in[above], right_in[below]);
      u = px::median3(u, up_in[before], up_in[after]);
      d = px::median3(d, down_in[before], down_in[after]);
    }
    left[i] = static_cast<std::uint8_t>(l);
    right[i] = static_cast<std::uint8_t>(r);
    up[i] = static_cast<std::uint8_t>(u);
    down[i] = static_cast<std::uint8_t>(d);
    shortest[i] = static_cast<std::uint8_t>(px::min_of(px::min_of(l, r), px::min_of(u, d)));
  }
};

// Pixels of each support region for both pass orders, as the reciprocals the means use.
struct RegionReciprocals {
  const std::uint8_t *left, *right, *up, *down;
  std::uint32_t *horizontal_first, *vertical_first;
  int width;
  DCO_HD void operator()(int x, int y) const {
    const std::size_t i = at(x, y, width);
    std::uint32_t hv = 0, vh = 0;
    for (int yy = y - up[i]; yy <= y + down[i]; ++yy) {
      const std::size_t j = at(x, yy, width);
      hv += std::uint32_t{left[j]} + right[j] + 1;
    }
    for (int xx = x - left[i]; xx <= x + right[i]; ++xx) {
      const std::size_t j = at(xx, y, width);
      vh += std::uint32_t{up[j]} + down[j] + 1;
    }
    horizontal_first[i] = px::reciprocal(hv);
    vertical_first[i] = px::reciprocal(vh);
  }
};

// Grid (width * depth, height): Eq. 1 for disparities 0 .. depth - 1.
struct CostVolume {
  const std::uint32_t *left, *right;
  const std::uint64_t *census_left, *census_right;
  const std::uint8_t* shortest;
  kernels::CostTableView tables;
  std::uint32_t* volume;
  int width, depth;
  DCO_HD void operator()(int i, int y) const {
    const int x = i / depth, d = i % depth;
    const std::size_t p = at(x, y, width);
    volume[at(x, y, d, width, depth)] =
        x >= d ? px::matching_cost(left[p], right[p - d], census_left[p], census_right[p - d],
                                   shortest[p], tables)
               : tables.unmatched;
  }
};

// Grid (depth, height): running sums along each row, in place.
struct RowRunningSums {
  std::uint32_t* volume;
  int width, depth;
  DCO_HD void operator()(int k, int y) const {
    std::uint32_t sum = 0;
    for (int x = 0; x < width; ++x) {
      std::uint32_t& v = volume[at(x, y, k, width, depth)];
      sum += v;
      v = sum;
    }
  }
};

// Grid (width * depth, 1): running sums down each column, in place.
struct ColumnRunningSums {
  std::uint32_t* volume;
  int width, height, depth;
  DCO_HD void operator()(int i, int) const {
    const int x = i / depth, k = i % depth;
    std::uint32_t sum = 0;
    for (int y = 0; y < height; ++y) {
      std::uint32_t& v = volume[at(x, y, k, width, depth)];
      sum += v;
      v = sum;
    }
  }
};

// Grid (width * depth, height): sums over the horizontal arms from row running sums; the region
// mean when `reciprocal` is set.
struct HorizontalArmSums {
  const std::uint32_t* running;
  std::uint32_t* out;
  const std::uint8_t *left, *right;
  const std::uint32_t* reciprocal;
  int width, depth;
  DCO_HD void operator()(int i, int y) const {
    const int x = i / depth, k = i % depth;
    const std::size_t p = at(x, y, width);
    const int first = x - left[p] - 1;
    std::uint32_t sum = running[at(x + right[p], y, k, width, depth)];
    if (first >= 0) sum -= running[at(first, y, k, width, depth)];
    out[at(x, y, k, width, depth)] = reciprocal ? px::region_mean(sum, reciprocal[p]) : sum;
  }
};

// Grid (width * depth, height): the same over the vertical arms from column running sums.
struct VerticalArmSums {
  const std::uint32_t* running;
  std::uint32_t* out;
  const std::uint8_t *up, *down;
  const std::uint32_t* reciprocal;
  int width, depth;
  DCO_HD void operator()(int i, int y) const {
    const int x = i / depth, k = i % depth;
    const std::size_t p = at(x, y, width);
    const int top = y - up[p] - 1;
    std::uint32_t sum = running[at(x, y + down[p], k, width, depth)];
    if (top >= 0) sum -= running[at(x, top, k, width, depth)];
    out[at(x, y, k, width, depth)] = reciprocal ? px::region_mean(sum, reciprocal[p]) : sum;
  }
};

// Grid (width, height): the left image's winner-takes-all over the aggregated volume.
struct WinnerLeft {
  const std::uint32_t* volume;
  int width, depth;
  std::int16_t* disp;
  std::uint16_t *best, *second, *below, *above;
  DCO_HD void operator()(int x, int y) const {
    px::WtaState s;
    const std::uint32_t* costs = volume + at(x, y, 0, width, depth);
    for (int d = 0; d < depth; ++d) px::wta_feed(s, static_cast<std::uint16_t>(costs[d]), d);
    const std::size_t p = at(x, y, width);
    disp[p] = s.disp;
    best[p] = s.best;
    second[p] = s.second;
    below[p] = s.below;
    above[p] = s.above;
  }
};

// Grid (width, height): the right image's winner at xr, from the left pixels xr + d.
struct WinnerRight {
  const std::uint32_t* volume;
  int width, depth;
  std::int16_t* disp;
  DCO_HD void operator()(int xr, int y) const {
    std::uint16_t best = kernels::kNoCost;
    std::int16_t winner = px::kInvalid;
    for (int d = 0; d < depth && xr + d < width; ++d) {
      const auto c = static_cast<std::uint16_t>(volume[at(xr + d, y, d, width, depth)]);
      if (c < best) {
        best = c;
        winner = static_cast<std::int16_t>(d);
      }
    }
    disp[at(xr, y, width)] = winner;
  }
};

// Left-right and uniqueness checks of the winners.
struct Checks {
  const std::int16_t *winner, *winner_right;
  const std::uint16_t *best, *second;
  std::int16_t* disp;
  int width, lr_max_diff;
  bool uniqueness;
  double keep;  // 1 - uniqueness ratio
  DCO_HD void operator()(int x, int y) const {
    const std::size_t p = at(x, y, width);
    std::int16_t d = winner[p];
    if (d != px::kInvalid &&
        !px::left_right_agree(x, d, winner_right + at(0, y, width), lr_max_diff))
      d = px::kInvalid;
    if (uniqueness && d != px::kInvalid && !px::unique_enough(best[p], second[p], keep))
      d = px::kInvalid;
    disp[p] = d;
  }
};

// Grid (width * depth, height): one histogram bin per disparity (Eq. 4).
struct VoteIndicators {
  const std::int16_t* disp;
  std::uint32_t* volume;
  int width, depth;
  DCO_HD void operator()(int i, int y) const {
    const int x = i / depth, k = i % depth;
    volume[at(x, y, k, width, depth)] = disp[at(x, y, width)] == k ? 1u : 0u;
  }
};

// Grid (width, height): the region's histogram decides the pixel (first of equal maxima wins).
struct VoteApply {
  const std::uint32_t* votes;
  std::int16_t* disp;
  std::uint8_t* changed;
  int width, depth;
  px::VoteParams rule;
  DCO_HD void operator()(int x, int y) const {
    const std::uint32_t* bins = votes + at(x, y, 0, width, depth);
    std::uint32_t total = 0, best = 0;
    std::int16_t winner = px::kInvalid;
    for (int k = 0; k < depth; ++k) {
      total += bins[k];
      if (bins[k] > best) {
        best = bins[k];
        winner = static_cast<std::int16_t>(k);
      }
    }
    const std::size_t p = at(x, y, width);
    const std::int16_t v = px::voted_value(disp[p], total, best, winner, rule);
    if (v != disp[p]) {
      disp[p] = v;
      changed[p] = 1;
    }
  }
};

struct Fill8 {
  std::uint8_t* data;
  int width;
  std::uint8_t value;
  DCO_HD void operator()(int x, int y) const { data[at(x, y, width)] = value; }
};

// Pixels beside a disparity jump lose their value (`in` is the map before the check).
struct JumpCheck {
  const std::int16_t* in;
  std::int16_t* out;
  int width, height, max_jump;
  DCO_HD void operator()(int x, int y) const {
    const std::int16_t* map = in;
    const int w = width;
    const auto value = [map, w](int xx, int yy) { return int{map[at(xx, yy, w)]}; };
    const std::int16_t d = map[at(x, y, w)];
    out[at(x, y, w)] = d != px::kInvalid && px::behind_jump(value, x, y, width, height, max_jump)
                           ? px::kInvalid
                           : d;
  }
};

// The raw (every pixel) and sparse (checked) disparities with their subpixel fits.
struct Disparities {
  const std::int16_t *winner, *disp;
  const std::uint16_t *below, *best, *above;
  const std::uint8_t* changed;
  float *raw, *sparse;
  int width;
  bool subpixel;
  float max_value;
  DCO_HD void operator()(int x, int y) const {
    const std::size_t p = at(x, y, width);
    raw[p] = px::raw_disparity(winner[p], below[p], best[p], above[p], subpixel, max_value);
    sparse[p] = px::sparse_disparity(disp[p], changed[p] != 0, below[p], best[p], above[p],
                                     subpixel, max_value);
  }
};

// Grid (input width, input height): the sparse map at input size, in input pixels.
struct ExpandToInput {
  const float* sparse;
  float* out;
  int width, height, out_width, scale;
  DCO_HD void operator()(int x, int y) const {
    const float v =
        sparse[at(px::min_of(x / scale, width - 1), px::min_of(y / scale, height - 1), width)];
    out[at(x, y, out_width)] = static_cast<float>(scale) * v;
  }
};

// Grid (w, h) of the internal map: the far and near side around each pixel (px::side_range),
// within kBoundaryReach and, for pixels without a value, within the rule's hole reach along the
// row (hole_far / hole_near; not written when the rule has no hole reach).
struct BoundarySides {
  const float* sparse;
  float* far;
  float* near;
  float* hole_far;
  float* hole_near;
  int width, height, hole_reach;
  DCO_HD void operator()(int x, int y) const {
    const px::SideRange r = px::side_range(sparse, width, width, height, x, y);
    far[at(x, y, width)] = r.far;
    near[at(x, y, width)] = r.near;
    if (hole_reach <= px::kBoundaryReach) return;
    const px::SideRange wide = px::side_range(sparse, width, width, height, x, y, hole_reach);
    hole_far[at(x, y, width)] = wide.far;
    hole_near[at(x, y, width)] = wide.near;
  }
};

// Grid (out_width, out_height) of the input: the boundary refinement, in place on `out` (each
// point reads and writes its own value only). The rule (with its weight table) travels by value;
// without a hole reach, hole_far / hole_near may be the narrow sides.
struct RefineBoundary {
  const std::uint8_t* left;
  const std::uint8_t* right;
  const float* far;
  const float* near;
  const float* hole_far;
  const float* hole_near;
  float* out;
  int width, height, out_width, out_height, scale;
  px::BoundaryRule rule;
  DCO_HD void operator()(int x, int y) const {
    const std::size_t i =
        at(px::min_of(x / scale, width - 1), px::min_of(y / scale, height - 1), width);
    const px::SideRange narrow{far[i], near[i]}, wide{hole_far[i], hole_near[i]};
    if (!px::spans_depth_edge(narrow) && !px::spans_depth_edge(wide)) return;
    const px::GreyPair im{left, right, out_width, out_width, out_width, out_height};
    float& v = out[at(x, y, out_width)];
    v = px::refined_boundary_value(im, x, y, v, narrow, wide, static_cast<float>(scale), rule);
  }
};

}  // namespace dco::gpu::passes
