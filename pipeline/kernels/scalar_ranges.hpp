#pragma once

// The scalar kernels over a range of columns: the whole row for dco::kernels::scalar, the last
// partial vector for the SIMD versions.

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "dco/kernels/stereo_kernels.hpp"
#include "dco/kernels/stereo_pixel.hpp"

namespace dco::kernels::detail {

inline void half_means_range(const std::uint8_t* a, const std::uint8_t* b, int begin, int end,
                             std::uint8_t* out) {
  for (int x = begin; x < end; ++x)
    out[x] = pixel::half_mean(a[2 * x], a[2 * x + 1], b[2 * x], b[2 * x + 1]);
}

using pixel::absdiff_sum;
using pixel::colour_diff;

// Columns [begin, end) of disparity_values_row.
inline void disparity_values_range(const DisparityRowInputs& in, bool subpixel, float max_value,
                                   int begin, int end, float* raw, float* sparse) {
  for (int x = begin; x < end; ++x) {
    raw[x] =
        pixel::raw_disparity(in.wta[x], in.below[x], in.best[x], in.above[x], subpixel, max_value);
    sparse[x] = pixel::sparse_disparity(in.checked[x], in.voted[x] != 0, in.below[x], in.best[x],
                                        in.above[x], subpixel, max_value);
  }
}

inline void census_range(const std::uint8_t* const* rows, int width, int window_w, int window_h,
                         int begin, int end, std::uint64_t* out) {
  const auto row = [rows](int j) { return rows[j]; };
  for (int x = begin; x < end; ++x) out[x] = pixel::census_bits(row, x, width, window_w, window_h);
}

// Length of the arm from `anchor` along `step` (elements), at most `limit` pixels. Pixels are
// packed words or grey bytes (a packed grey pixel is its byte).
template <class Pixel>
int arm_length(const Pixel* anchor, std::ptrdiff_t step, int limit, const ArmParams& p) {
  return pixel::arm_length(
      std::uint32_t{*anchor}, [anchor, step](int i) { return std::uint32_t{anchor[step * i]}; },
      limit, p);
}

// Arms of columns [begin, end) of row y.
template <class Pixel>
void arms_range(const Pixel* image, std::ptrdiff_t stride, int width, int height, int y,
                const ArmParams& p, int begin, int end, std::uint8_t* left, std::uint8_t* right,
                std::uint8_t* up, std::uint8_t* down) {
  const Pixel* row = image + y * stride;
  for (int x = begin; x < end; ++x) {
    const Pixel* a = row + x;
    left[x] = static_cast<std::uint8_t>(arm_length(a, -1, std::min(p.arm_max, x), p));
    right[x] = static_cast<std::uint8_t>(arm_length(a, 1, std::min(p.arm_max, width - 1 - x), p));
    up[x] = static_cast<std::uint8_t>(arm_length(a, -stride, std::min(p.arm_max, y), p));
    down[x] =
        static_cast<std::uint8_t>(arm_length(a, stride, std::min(p.arm_max, height - 1 - y), p));
  }
}

// Cost of left pixel x at disparity d <= x.
inline std::uint32_t matched_cost(const CostRow& row, const CostTableView& t, int x, int d) {
  return pixel::matching_cost(row.left[x], row.right[x - d], row.census_left[x],
                              row.census_right[x - d], row.shortest_arm[x], t);
}

// Columns [begin, end), all >= d.
inline void matched_cost_range(const CostRow& row, const CostTableView& t, int d, int begin,
                               int end, std::uint32_t* out) {
  for (int x = begin; x < end; ++x) out[x] = matched_cost(row, t, x, d);
}

// Block layout: disparities d0 + [begin, end) of pixel x.
inline void block_cost_range(const CostRow& row, const CostTableView& t, int x, int d0, int count,
                             int begin, int end, std::uint32_t* out) {
  for (int k = begin; k < end; ++k)
    out[x * count + k] = x >= d0 + k ? matched_cost(row, t, x, d0 + k) : t.unmatched;
}

inline void prefix_sums(const std::uint32_t* in, int width, std::uint32_t* prefix) {
  prefix[0] = 0;
  for (int x = 0; x < width; ++x) prefix[x + 1] = prefix[x] + in[x];
}

inline void horizontal_range(const std::uint32_t* prefix, const std::uint8_t* left,
                             const std::uint8_t* right, int begin, int end, std::uint32_t* out) {
  for (int x = begin; x < end; ++x) out[x] = prefix[x + right[x] + 1] - prefix[x - left[x]];
}

inline void vertical_range(const std::uint32_t* column_sums, std::ptrdiff_t stride, int y,
                           const std::uint8_t* up, const std::uint8_t* down, int begin, int end,
                           std::uint32_t* out) {
  for (int x = begin; x < end; ++x) {
    const int top = y - up[x] - 1;
    const std::uint32_t below_sum = column_sums[(y + down[x]) * stride + x];
    out[x] = top >= 0 ? below_sum - column_sums[top * stride + x] : below_sum;
  }
}

inline void mean_range(std::uint32_t* row, const std::uint32_t* reciprocal, int begin, int end) {
  for (int x = begin; x < end; ++x) row[x] = pixel::region_mean(row[x], reciprocal[x]);
}

inline void reciprocal_range(const std::uint32_t* size, int begin, int end, std::uint32_t* out) {
  for (int x = begin; x < end; ++x) out[x] = pixel::reciprocal(size[x]);
}

// Block layout: elements [begin, end) of every block.
inline void block_prefix_range(const std::uint32_t* in, int width, int block, int begin, int end,
                               std::uint32_t* prefix) {
  for (int k = begin; k < end; ++k) prefix[k] = 0;
  for (int x = 0; x < width; ++x)
    for (int k = begin; k < end; ++k)
      prefix[(x + 1) * block + k] = prefix[x * block + k] + in[x * block + k];
}

inline void block_horizontal_range(const std::uint32_t* prefix, const std::uint8_t* left,
                                   const std::uint8_t* right, int width, int block, int begin,
                                   int end, const std::uint32_t* above, std::uint32_t* out) {
  for (int x = 0; x < width; ++x) {
    const std::uint32_t* hi = prefix + (x + right[x] + 1) * block;
    const std::uint32_t* lo = prefix + (x - left[x]) * block;
    for (int k = begin; k < end; ++k)
      out[x * block + k] = hi[k] - lo[k] + (above ? above[x * block + k] : 0u);
  }
}

inline void block_vertical_range(const std::uint32_t* const* column_rows, int y,
                                 const std::uint8_t* up, const std::uint8_t* down, int width,
                                 int block, int begin, int end, const std::uint32_t* reciprocal,
                                 std::uint32_t* out) {
  for (int x = 0; x < width; ++x) {
    const int top = y - up[x] - 1;
    const std::uint32_t* below = column_rows[y + down[x]] + x * block;
    const std::uint32_t* above = top >= 0 ? column_rows[top] + x * block : nullptr;
    for (int k = begin; k < end; ++k) {
      const std::uint32_t sum = above ? below[k] - above[k] : below[k];
      out[x * block + k] = reciprocal ? pixel::region_mean(sum, reciprocal[x]) : sum;
    }
  }
}

// Pixels [x_begin, width) of elements [k_begin, count), and elements [k_end, count) of pixels
// [0, x_begin): what the 4x4 tiles leave.
inline void blocks_to_rows_rest(const std::uint32_t* blocks, int width, int block, int count,
                                int x_begin, int k_end, std::uint16_t* rows,
                                std::ptrdiff_t row_stride) {
  for (int k = 0; k < count; ++k) {
    std::uint16_t* dst = rows + k * row_stride;
    for (int x = k < k_end ? x_begin : 0; x < width; ++x)
      dst[x] = static_cast<std::uint16_t>(blocks[x * block + k]);
  }
}

inline void block_indicator_range(const std::int16_t* value, int width,
                                  const std::int32_t* candidates, int count, int begin, int end,
                                  std::uint32_t* out) {
  for (int x = 0; x < width; ++x)
    for (int k = begin; k < end; ++k) out[x * count + k] = value[x] == candidates[k];
}

// Bins [begin, end) of pixel x.
inline void block_vote_range(const std::uint32_t* votes, int x, const std::int32_t* candidates,
                             int count, int begin, int end, std::uint32_t* total,
                             std::uint32_t* best_votes, std::int16_t* best_value) {
  for (int k = begin; k < end; ++k) {
    const std::uint32_t v = votes[x * count + k];
    total[x] += v;
    if (v > best_votes[x]) {
      best_votes[x] = v;
      best_value[x] = static_cast<std::int16_t>(candidates[k]);
    }
  }
}

// The left image's state: columns [begin, end).
// The left image's state of columns [begin, end) as it is before disparity 0.
inline void wta_start_range(int begin, int end, const WtaRow& r) {
  for (int x = begin; x < end; ++x)
    pixel::wta_start(r.best[x], r.second[x], r.below[x], r.above[x], r.prev1[x], r.prev2[x],
                     r.runmin[x], r.disp[x]);
}

inline void wta_left_range(const std::uint16_t* cost, int begin, int end, int d, const WtaRow& r) {
  for (int x = begin; x < end; ++x)
    pixel::wta_feed(cost[x], d, r.best[x], r.second[x], r.below[x], r.above[x], r.prev1[x],
                    r.prev2[x], r.runmin[x], r.disp[x]);
}

// The right image's state: left columns [begin, end), all >= d (right column x - d).
inline void wta_right_range(const std::uint16_t* cost, int begin, int end, int d, const WtaRow& r) {
  const auto dd = static_cast<std::int16_t>(d);
  for (int x = begin; x < end; ++x) {
    const std::uint16_t c = cost[x];
    if (c < r.best_right[x - d]) {
      r.best_right[x - d] = c;
      r.disp_right[x - d] = dd;
    }
  }
}

}  // namespace dco::kernels::detail
