#include <algorithm>

#include "dco/kernels/stereo_kernels.hpp"
#include "scalar_ranges.hpp"

namespace dco::kernels {

namespace {

// One channel (the headset's grey images): each byte widened, a loop the compiler vectorises.
void widen_bytes(const std::uint8_t* __restrict src, int width, std::uint32_t* __restrict out) {
  for (int x = 0; x < width; ++x) out[x] = src[x];
}

}  // namespace

void pack_pixels(const std::uint8_t* src, int channels, int width, std::uint32_t* out) {
  if (channels == 1) {
    widen_bytes(src, width, out);
    return;
  }
  for (int x = 0; x < width; ++x) {
    std::uint32_t word = 0;
    for (int c = 0; c < channels; ++c) word |= std::uint32_t{src[x * channels + c]} << (8 * c);
    out[x] = word;
  }
}

namespace scalar {

void disparity_values_row(const DisparityRowInputs& in, int width, bool subpixel, float max_value,
                          float* raw, float* sparse) {
  detail::disparity_values_range(in, subpixel, max_value, 0, width, raw, sparse);
}

void half_means_row(const std::uint8_t* a, const std::uint8_t* b, int count, std::uint8_t* out) {
  detail::half_means_range(a, b, 0, count, out);
}

void census_row(const std::uint8_t* const* rows, int width, int window_w, int window_h,
                std::uint64_t* out) {
  detail::census_range(rows, width, window_w, window_h, 0, width, out);
}

void cross_arms_row(const std::uint32_t* image, std::ptrdiff_t stride, int width, int height, int y,
                    const ArmParams& params, std::uint8_t* left, std::uint8_t* right,
                    std::uint8_t* up, std::uint8_t* down) {
  detail::arms_range(image, stride, width, height, y, params, 0, width, left, right, up, down);
}

void grey_cross_arms_row(const std::uint8_t* image, std::ptrdiff_t stride, int width, int height,
                         int y, const ArmParams& params, std::uint8_t* left, std::uint8_t* right,
                         std::uint8_t* up, std::uint8_t* down) {
  detail::arms_range(image, stride, width, height, y, params, 0, width, left, right, up, down);
}

void matching_cost_row(const CostRow& row, const CostTableView& tables, int d, std::uint32_t* out) {
  const int first = std::min(d, row.width);
  std::fill(out, out + first, tables.unmatched);
  detail::matched_cost_range(row, tables, d, first, row.width, out);
}

void block_matching_cost_row(const CostRow& row, const CostTableView& tables, int d0, int count,
                             std::uint32_t* out) {
  for (int x = 0; x < row.width; ++x)
    detail::block_cost_range(row, tables, x, d0, count, 0, count, out);
}

void block_matching_cost_sums_row(const CostRow& row, const CostTableView& tables, int d0,
                                  int count, std::uint32_t* prefix) {
  scalar::block_matching_cost_sums_range(row, tables, d0, count, 0, row.width, prefix);
}

void block_matching_cost_sums_range(const CostRow& row, const CostTableView& tables, int d0,
                                    int count, int begin, int end, std::uint32_t* prefix) {
  // The costs one block further on, then summed in place along the row.
  for (int x = begin; x < end; ++x)
    detail::block_cost_range(row, tables, x, d0, count, 0, count, prefix + count);
  for (int k = 0; k < count; ++k) prefix[begin * count + k] = 0;
  for (int x = begin; x < end; ++x)
    for (int k = 0; k < count; ++k) prefix[(x + 1) * count + k] += prefix[x * count + k];
}

void block_window_sums_row(const std::uint32_t* prefix, const std::uint8_t* left,
                           const std::uint8_t* right, int width, int block,
                           const std::uint32_t* above, std::uint32_t* out) {
  detail::block_horizontal_range(prefix, left, right, width, block, 0, block, above, out);
}

void horizontal_sums_row(const std::uint32_t* in, const std::uint8_t* left,
                         const std::uint8_t* right, int width, std::uint32_t* prefix,
                         std::uint32_t* out) {
  detail::prefix_sums(in, width, prefix);
  detail::horizontal_range(prefix, left, right, 0, width, out);
}

void accumulate_row(const std::uint32_t* above, std::uint32_t* row, int width) {
  for (int x = 0; x < width; ++x) row[x] += above[x];
}

void vertical_sums_row(const std::uint32_t* column_sums, std::ptrdiff_t stride, int y,
                       const std::uint8_t* up, const std::uint8_t* down, int width,
                       std::uint32_t* out) {
  detail::vertical_range(column_sums, stride, y, up, down, 0, width, out);
}

void region_mean_row(std::uint32_t* row, const std::uint32_t* reciprocal, int width) {
  detail::mean_range(row, reciprocal, 0, width);
}

void region_reciprocal_row(const std::uint32_t* size, int width, std::uint32_t* out) {
  detail::reciprocal_range(size, 0, width, out);
}

void block_horizontal_sums_row(const std::uint32_t* in, const std::uint8_t* left,
                               const std::uint8_t* right, int width, int block,
                               std::uint32_t* prefix, const std::uint32_t* above,
                               std::uint32_t* out) {
  detail::block_prefix_range(in, width, block, 0, block, prefix);
  detail::block_horizontal_range(prefix, left, right, width, block, 0, block, above, out);
}

void block_vertical_sums_row(const std::uint32_t* const* column_rows, int y, const std::uint8_t* up,
                             const std::uint8_t* down, int width, int block,
                             const std::uint32_t* reciprocal, std::uint32_t* out) {
  detail::block_vertical_range(column_rows, y, up, down, width, block, 0, block, reciprocal, out);
}

void blocks_to_rows(const std::uint32_t* blocks, int width, int block, int count,
                    std::uint16_t* rows, std::ptrdiff_t row_stride) {
  detail::blocks_to_rows_rest(blocks, width, block, count, 0, count, rows, row_stride);
}

void block_indicator_row(const std::int16_t* value, int width, const std::int32_t* candidates,
                         int count, std::uint32_t* out) {
  detail::block_indicator_range(value, width, candidates, count, 0, count, out);
}

void block_vote_row(const std::uint32_t* votes, int width, const std::int32_t* candidates,
                    int count, std::uint32_t* total, std::uint32_t* best_votes,
                    std::int16_t* best_value) {
  for (int x = 0; x < width; ++x)
    detail::block_vote_range(votes, x, candidates, count, 0, count, total, best_votes, best_value);
}

void wta_update_row(const std::uint16_t* cost, std::ptrdiff_t cost_stride, int count, int width,
                    int d, const WtaRow& row) {
  scalar::wta_update_range(cost, cost_stride, count, 0, width, d, row);
}

void wta_update_range(const std::uint16_t* cost, std::ptrdiff_t cost_stride, int count, int begin,
                      int end, int d, const WtaRow& row) {
  if (d == 0) detail::wta_start_range(begin, end, row);
  for (int k = 0; k < count; ++k) {
    const std::uint16_t* c = cost + k * cost_stride;
    detail::wta_left_range(c, begin, end, d + k, row);
    detail::wta_right_range(c, std::min(std::max(d + k, begin), end), end, d + k, row);
  }
}

void wta_skip_row(int count, int width, int d, const WtaRow& row) {
  scalar::wta_skip_range(count, 0, width, d, row);
}

void wta_skip_range(int count, int begin, int end, int d, const WtaRow& row) {
  if (d == 0) detail::wta_start_range(begin, end, row);
  for (int x = begin; x < end; ++x)
    pixel::wta_skip(d, count, row.above[x], row.prev1[x], row.prev2[x], row.runmin[x], row.disp[x]);
}

void left_right_check_row(std::int16_t* left, const std::int16_t* right, int width, int max_diff) {
  for (int x = 0; x < width; ++x)
    if (left[x] != pixel::kInvalid && !pixel::left_right_agree(x, left[x], right, max_diff))
      left[x] = pixel::kInvalid;
}

void uniqueness_check_row(std::int16_t* disparity, const std::uint16_t* best,
                          const std::uint16_t* second, int width, double keep) {
  for (int x = 0; x < width; ++x)
    if (!pixel::unique_enough(best[x], second[x], keep)) disparity[x] = pixel::kInvalid;
}

}  // namespace scalar
}  // namespace dco::kernels
