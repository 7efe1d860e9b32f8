#pragma once

#include <cstddef>
#include <cstdint>

// Row kernels of the sparse stereo stage. Every function in dco::kernels dispatches at run time
// to the best SIMD target the CPU offers (Highway: SSE4/AVX2/AVX-512 on x86, NEON/SVE on Arm);
// the functions of the same name in dco::kernels::scalar are the plain references, and the vector
// versions give bit-identical results (all arithmetic is integer). They take plain pointers and
// need nothing but Highway (inside) and the C++ library, so they build and test on any target.
namespace dco::kernels {

// Name of the SIMD target the dispatch picks on this CPU ("AVX2", "AVX3", "NEON", "SVE2", ...).
const char* simd_target();

// One pixel of up to four 8-bit channels in one word (channel c in bits 8c..8c+7, unused channels
// zero), so the absolute-difference sum over the channels is a handful of lane operations.
void pack_pixels(const std::uint8_t* src, int channels, int width, std::uint32_t* out);

// out[x] = pixel::half_mean(a[2x], a[2x + 1], b[2x], b[2x + 1]) for x < count: a grey row pair
// halved (the stereo stage's internal resolution and its coarse passes).
void half_means_row(const std::uint8_t* a, const std::uint8_t* b, int count, std::uint8_t* out);

// Census transform of one row (dco::stereo::census_transform): rows[j] is image row y + j - ry,
// clamped to the image, for j = 0 .. window_h - 1 (odd sizes, window_w * window_h - 1 <= 64).
// Bits in row-major neighbour order from the most significant used bit down, set where the
// neighbour (columns clamped to the row) is darker than the centre.
void census_row(const std::uint8_t* const* rows, int width, int window_w, int window_h,
                std::uint64_t* out);

// Adaptive cross arms (dco::stereo::compute_cross_arms) of the pixels of row y of a packed image
// (`height` rows, `stride` elements apart). An arm grows while the colour difference (the
// largest channel difference) to the anchor and to the previous pixel stays below tau1, and
// beyond arm_short the difference to the anchor below tau2, up to arm_max and the image border.
struct ArmParams {
  int arm_max = 0;
  int arm_short = 0;
  int tau1 = 0;
  int tau2 = 0;
};
void cross_arms_row(const std::uint32_t* image, std::ptrdiff_t stride, int width, int height, int y,
                    const ArmParams& params, std::uint8_t* left, std::uint8_t* right,
                    std::uint8_t* up, std::uint8_t* down);
// The same on a grey image (one byte per pixel, `stride` bytes apart): the arms cross_arms_row
// gives for its packed pixels, a vector lane per byte instead of per word.
void grey_cross_arms_row(const std::uint8_t* image, std::ptrdiff_t stride, int width, int height,
                         int y, const ArmParams& params, std::uint8_t* left, std::uint8_t* right,
                         std::uint8_t* up, std::uint8_t* down);

// Flat fixed-point cost tables of Eq. 1 (see dco::stereo::CostTables): the AD term of pixel x is
// ad[arm[x] * ad_size + sum of |channel differences|], the census term
// census[arm[x] * census_size + Hamming distance].
struct CostTableView {
  const std::uint32_t* ad = nullptr;
  int ad_size = 0;  // 255 channels + 1; 256: one channel, whose packed pixels are the grey level
  const std::uint32_t* census = nullptr;
  int census_size = 0;
  std::uint32_t unmatched = 0;  // cost of a left pixel whose partner x - d is outside the image
  // Every arm's AD row is constant from this index on (0: not known). A short enough head lets
  // the kernel look the AD term up in registers instead of gathering it.
  int ad_flat_from = 0;
};

// One image row: packed pixels, census descriptors and the shortest arm of each left pixel.
struct CostRow {
  const std::uint32_t* left = nullptr;
  const std::uint32_t* right = nullptr;
  const std::uint64_t* census_left = nullptr;
  const std::uint64_t* census_right = nullptr;
  const std::uint8_t* shortest_arm = nullptr;
  int width = 0;
};

// out[x] = cost of matching left pixel x with right pixel x - d (0 <= d).
void matching_cost_row(const CostRow& row, const CostTableView& tables, int d, std::uint32_t* out);
// The costs of disparities d0 .. d0 + count - 1 in block layout (see below): out[x * count + k] =
// cost of left pixel x at disparity d0 + k.
void block_matching_cost_row(const CostRow& row, const CostTableView& tables, int d0, int count,
                             std::uint32_t* out);
// Their running sums along the row instead, as block_horizontal_sums_row's prefix:
// prefix[(x + 1) * count + k] = prefix[x * count + k] + cost, prefix[0 .. count) = 0
// ((width + 1) * count elements, uint32 wrap-around).
void block_matching_cost_sums_row(const CostRow& row, const CostTableView& tables, int d0,
                                  int count, std::uint32_t* prefix);
// The same for the row's pixels [begin, end) only, the sums starting over at `begin`:
// prefix[begin * count .. (begin + 1) * count) = 0 and prefix[(x + 1) * count + k] for x in
// [begin, end); a window sum inside [begin, end) is the same as from the whole row's sums.
void block_matching_cost_sums_range(const CostRow& row, const CostTableView& tables, int d0,
                                    int count, int begin, int end, std::uint32_t* prefix);

// out[x] = sum of in[x - left[x] .. x + right[x]] with uint32 wrap-around; arms stay inside the
// row. `prefix` holds width + 1 elements of scratch.
void horizontal_sums_row(const std::uint32_t* in, const std::uint8_t* left,
                         const std::uint8_t* right, int width, std::uint32_t* prefix,
                         std::uint32_t* out);

// row[x] += above[x]: one step of running column sums.
void accumulate_row(const std::uint32_t* above, std::uint32_t* row, int width);

// out[x] = column_sums(x, y + down[x]) - column_sums(x, y - up[x] - 1) (0 above row 0), where
// column_sums (`stride` elements between rows, rows 0 .. y + max down) holds running column sums:
// the sum over the vertical arm [y - up, y + down] of the summed column.
void vertical_sums_row(const std::uint32_t* column_sums, std::ptrdiff_t stride, int y,
                       const std::uint8_t* up, const std::uint8_t* down, int width,
                       std::uint32_t* out);

// row[x] = (row[x] * reciprocal[x] + 2^30) >> 31 in 64-bit arithmetic: the region mean when
// reciprocal = round(2^31 / region size).
void region_mean_row(std::uint32_t* row, const std::uint32_t* reciprocal, int width);
// out[x] = pixel::reciprocal(size[x]) = round(2^31 / size[x]), for sizes in [1, 2^21) (a region
// of 511 x 511 pixels at most is far inside).
void region_reciprocal_row(const std::uint32_t* size, int width, std::uint32_t* out);

// The same sums over rows of blocks: element k of block x sits at [x * block + k] (one block per
// pixel, e.g. one element per disparity), and every element of a block shares the pixel's arms
// and reciprocal, so the work is whole-vector loads instead of gathers. Elements past a block's
// last whole vector take scalar code: blocks of 16 are whole vectors on every target up to 512
// bits.
// prefix: (width + 1) * block elements; out[x * block + k] = sum of in[i * block + k] over
// i in [x - left[x], x + right[x]], plus above[x * block + k] when `above` is given (the running
// column sums of the previous row: the column accumulation in the same pass).
void block_horizontal_sums_row(const std::uint32_t* in, const std::uint8_t* left,
                               const std::uint8_t* right, int width, int block,
                               std::uint32_t* prefix, const std::uint32_t* above,
                               std::uint32_t* out);
// The second half of block_horizontal_sums_row, from prefix sums already made (e.g. by
// block_matching_cost_sums_row).
void block_window_sums_row(const std::uint32_t* prefix, const std::uint8_t* left,
                           const std::uint8_t* right, int width, int block,
                           const std::uint32_t* above, std::uint32_t* out);
// column_rows[i]: row i of the running column sums, width * block elements (a table of row
// pointers, so the rows may live in a ring buffer); rows y - up - 1 .. y + down are read. With
// `reciprocal`, out holds the region means of the sums instead (region_mean_row per element).
void block_vertical_sums_row(const std::uint32_t* const* column_rows, int y, const std::uint8_t* up,
                             const std::uint8_t* down, int width, int block,
                             const std::uint32_t* reciprocal, std::uint32_t* out);
// Back to one row per block element: rows[k * row_stride + x] = blocks[x * block + k] for
// k < count (<= block), as the 16-bit costs the winner-takes-all state takes (every value must
// be below kNoCost).
void blocks_to_rows(const std::uint32_t* blocks, int width, int block, int count,
                    std::uint16_t* rows, std::ptrdiff_t row_stride);

// out[x * count + k] = 1 where value[x] == candidates[k], else 0: one histogram bin per block
// element (count >= 1).
void block_indicator_row(const std::int16_t* value, int width, const std::int32_t* candidates,
                         int count, std::uint32_t* out);
// Tallies the region sums of those bins (votes < 2^31): total[x] += the sum of pixel x's block;
// where a bin beats best_votes[x], in bin order and strictly, it becomes best_votes[x] and its
// candidate best_value[x] (so the first of equal maxima wins).
void block_vote_row(const std::uint32_t* votes, int width, const std::int32_t* candidates,
                    int count, std::uint32_t* total, std::uint32_t* best_votes,
                    std::int16_t* best_value);

// Winner-takes-all state of one row (see dco::stereo::WinnerTakesAll).
struct WtaRow {
  std::uint16_t* best = nullptr;
  std::uint16_t* second = nullptr;  // best cost at least two disparities from the winner
  std::uint16_t* below = nullptr;   // cost at winner - 1
  std::uint16_t* above = nullptr;   // cost at winner + 1
  std::uint16_t* prev1 = nullptr;   // cost at d - 1
  std::uint16_t* prev2 = nullptr;   // cost at d - 2
  std::uint16_t* runmin = nullptr;  // best cost over disparities <= d - 3 (before this update)
  std::int16_t* disp = nullptr;
  std::uint16_t* best_right = nullptr;  // right image, indexed by xr = x - d
  std::int16_t* disp_right = nullptr;
};

inline constexpr std::uint16_t kNoCost = 0xffff;

// Feeds the costs of disparities d .. d + count - 1, those of d + k at cost + k * cost_stride
// (disparities grow by one from 0 over the calls). A cost of kNoCost leaves that disparity out
// for that pixel, as wta_skip_row does, and never reaches the right image's state. Several
// disparities per call keep the state in registers in between. A call for d = 0 (update or
// skip) starts the left image's state of its pixels afresh (pixel::WtaState's values) without
// reading it, so only the right image's state needs setting before the first disparity.
void wta_update_row(const std::uint16_t* cost, std::ptrdiff_t cost_stride, int count, int width,
                    int d, const WtaRow& row);
// The same for the left pixels [begin, end) only (costs and state indexed by column): the
// right image's state sees only the costs of those left pixels.
void wta_update_range(const std::uint16_t* cost, std::ptrdiff_t cost_stride, int count, int begin,
                      int end, int d, const WtaRow& row);
// Passes over disparities d .. d + count - 1 of a row that does not search them
// (pixel::wta_skip): the state's neighbours and running minima take them as costless.
void wta_skip_row(int count, int width, int d, const WtaRow& row);
// The same for the left pixels [begin, end) only.
void wta_skip_range(int count, int begin, int end, int d, const WtaRow& row);

// Left-right check of one row (pixel::left_right_agree): left[x] becomes pixel::kInvalid where
// the right image's winner at x - left[x] disagrees by more than max_diff or lies outside the row.
// `scratch` holds `width` values (the right row widened for the lookups).
void left_right_check_row(std::int16_t* left, const std::int16_t* right, int width, int max_diff,
                          std::int32_t* scratch);

// Uniqueness check of one row (pixel::unique_enough): disparity[x] becomes pixel::kInvalid unless
// best[x] <= keep * second[x] (in double, as the pixel rule) or second[x] is kNoCost.
void uniqueness_check_row(std::int16_t* disparity, const std::uint16_t* best,
                          const std::uint16_t* second, int width, double keep);

// One row of the internal disparity maps from the winner-takes-all state: raw[x] =
// pixel::raw_disparity(wta[x], ...) and sparse[x] = pixel::sparse_disparity(checked[x],
// voted[x] != 0, ...), with the costs below, at and above the winner.
struct DisparityRowInputs {
  const std::int16_t* wta = nullptr;      // winner of each pixel
  const std::int16_t* checked = nullptr;  // after the checks and the vote (kInvalid: none)
  const std::uint8_t* voted = nullptr;    // nonzero where the vote changed the value
  const std::uint16_t* below = nullptr;
  const std::uint16_t* best = nullptr;
  const std::uint16_t* above = nullptr;
};
void disparity_values_row(const DisparityRowInputs& in, int width, bool subpixel, float max_value,
                          float* raw, float* sparse);

namespace scalar {
void half_means_row(const std::uint8_t* a, const std::uint8_t* b, int count, std::uint8_t* out);

void disparity_values_row(const DisparityRowInputs& in, int width, bool subpixel, float max_value,
                          float* raw, float* sparse);
void census_row(const std::uint8_t* const* rows, int width, int window_w, int window_h,
                std::uint64_t* out);
void cross_arms_row(const std::uint32_t* image, std::ptrdiff_t stride, int width, int height, int y,
                    const ArmParams& params, std::uint8_t* left, std::uint8_t* right,
                    std::uint8_t* up, std::uint8_t* down);
void grey_cross_arms_row(const std::uint8_t* image, std::ptrdiff_t stride, int width, int height,
                         int y, const ArmParams& params, std::uint8_t* left, std::uint8_t* right,
                         std::uint8_t* up, std::uint8_t* down);
void block_matching_cost_row(const CostRow& row, const CostTableView& tables, int d0, int count,
                             std::uint32_t* out);
void block_matching_cost_sums_row(const CostRow& row, const CostTableView& tables, int d0,
                                  int count, std::uint32_t* prefix);
void block_matching_cost_sums_range(const CostRow& row, const CostTableView& tables, int d0,
                                    int count, int begin, int end, std::uint32_t* prefix);
void matching_cost_row(const CostRow& row, const CostTableView& tables, int d, std::uint32_t* out);
void horizontal_sums_row(const std::uint32_t* in, const std::uint8_t* left,
                         const std::uint8_t* right, int width, std::uint32_t* prefix,
                         std::uint32_t* out);
void accumulate_row(const std::uint32_t* above, std::uint32_t* row, int width);
void vertical_sums_row(const std::uint32_t* column_sums, std::ptrdiff_t stride, int y,
                       const std::uint8_t* up, const std::uint8_t* down, int width,
                       std::uint32_t* out);
void region_mean_row(std::uint32_t* row, const std::uint32_t* reciprocal, int width);
void region_reciprocal_row(const std::uint32_t* size, int width, std::uint32_t* out);
void block_horizontal_sums_row(const std::uint32_t* in, const std::uint8_t* left,
                               const std::uint8_t* right, int width, int block,
                               std::uint32_t* prefix, const std::uint32_t* above,
                               std::uint32_t* out);
void block_window_sums_row(const std::uint32_t* prefix, const std::uint8_t* left,
                           const std::uint8_t* right, int width, int block,
                           const std::uint32_t* above, std::uint32_t* out);
void block_vertical_sums_row(const std::uint32_t* const* column_rows, int y, const std::uint8_t* up,
                             const std::uint8_t* down, int width, int block,
                             const std::uint32_t* reciprocal, std::uint32_t* out);
void blocks_to_rows(const std::uint32_t* blocks, int width, int block, int count,
                    std::uint16_t* rows, std::ptrdiff_t row_stride);
void block_indicator_row(const std::int16_t* value, int width, const std::int32_t* candidates,
                         int count, std::uint32_t* out);
void block_vote_row(const std::uint32_t* votes, int width, const std::int32_t* candidates,
                    int count, std::uint32_t* total, std::uint32_t* best_votes,
                    std::int16_t* best_value);
void wta_update_row(const std::uint16_t* cost, std::ptrdiff_t cost_stride, int count, int width,
                    int d, const WtaRow& row);
void wta_update_range(const std::uint16_t* cost, std::ptrdiff_t cost_stride, int count, int begin,
                      int end, int d, const WtaRow& row);
void wta_skip_row(int count, int width, int d, const WtaRow& row);
void wta_skip_range(int count, int begin, int end, int d, const WtaRow& row);
void left_right_check_row(std::int16_t* left, const std::int16_t* right, int width, int max_diff);
void uniqueness_check_row(std::int16_t* disparity, const std::uint16_t* best,
                          const std::uint16_t* second, int width, double keep);

}  // namespace scalar
}  // namespace dco::kernels
