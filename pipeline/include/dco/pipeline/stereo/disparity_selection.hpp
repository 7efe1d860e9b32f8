#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "dco/core/image.hpp"
#include "dco/kernels/stereo_pixel.hpp"

namespace dco::kernels {
struct WtaRow;
}

namespace dco::stereo {

inline constexpr std::int16_t kInvalidDisparity = kernels::pixel::kInvalid;

// Winner-takes-all over aggregated cost slices fed in increasing disparity order (Eq. 3), for
// the left image and, from the same slices, for the right image (a right pixel xr at disparity d
// is the left pixel xr + d). Alongside the winner it keeps what the checks need: the best cost
// at least two disparities away (uniqueness) and the costs at d-1 and d+1 (subpixel fit), so
// the cost volume itself is never stored.
class WinnerTakesAll {
 public:
  static constexpr std::uint16_t kNoCost = 0xffff;

  // Sizes the state and starts the right image's. The left image's starts with each pixel's
  // disparity 0 (kernels::wta_update_range), so every pixel must see it, updated or skipped.
  void reset(int width, int height);
  // Slice values must be < kNoCost; d must grow by one from 0 between calls.
  void update(ImageView<const std::uint32_t> slice, int d);
  // Row y of such a slice: what update does for that row.
  void update_slice_row(const std::uint32_t* costs, int y, int d);
  // Row y of the slices of disparities d .. d + count - 1 at once, that of d + k at
  // costs + k * stride: the same result as `count` calls of update. A cost of kNoCost leaves
  // that disparity out for that pixel (as skip_row does), and the right image's state does not
  // take it in.
  void update_row(const std::uint16_t* costs, std::ptrdiff_t stride, int count, int y, int d);
  // Row y leaves disparities d .. d + count - 1 out of its search: the same result as
  // update_row with every cost kNoCost.
  void skip_row(int y, int d, int count);
  // These three for the columns [begin, end) of row y only (costs indexed by column, as above):
  // every column must still see each disparity once, updated or skipped.
  void update_slice_columns(const std::uint32_t* costs, int y, int d, int begin, int end);
  void update_columns(const std::uint16_t* costs, std::ptrdiff_t stride, int count, int y, int d,
                      int begin, int end);
  void skip_columns(int y, int d, int count, int begin, int end);

  ImageView<const std::int16_t> left_disparity() const { return disp_.view(); }
  ImageView<const std::int16_t> right_disparity() const { return disp_right_.view(); }
  ImageView<const std::uint16_t> best_cost() const { return best_.view(); }
  ImageView<const std::uint16_t> second_cost() const { return second_.view(); }
  ImageView<const std::uint16_t> cost_below() const { return below_.view(); }
  ImageView<const std::uint16_t> cost_above() const { return above_.view(); }

 private:
  kernels::WtaRow state_row(int y);

  Image<std::uint16_t> best_, second_, below_, above_, prev1_, prev2_, runmin_, best_right_;
  Image<std::int16_t> disp_, disp_right_;
  std::vector<std::uint16_t> narrowed_;  // one slice row as 16-bit costs
};

// Marks kInvalidDisparity where the right image's winner at x - d(x) differs from d(x) by more
// than max_diff (occlusions and mismatches), or where x - d(x) falls outside the image.
// `scratch` is sized on first use and reused.
void left_right_check(ImageView<std::int16_t> left, ImageView<const std::int16_t> right,
                      int max_diff, std::vector<std::int32_t>& scratch);

// Marks kInvalidDisparity where the best cost is not at least `ratio` below the best cost of a
// non-adjacent disparity (ambiguous matches: repetitive texture, flat regions).
void uniqueness_check(ImageView<std::int16_t> disparity, ImageView<const std::uint16_t> best,
                      ImageView<const std::uint16_t> second, double ratio);

// Marks kInvalidDisparity where a reliable 8-neighbour's disparity is larger by more than
// max_jump: at depth discontinuities half-resolution blocks and aggregation windows straddle two
// surfaces; the contour-aware densify stage places the edge instead. Only the far side of a jump
// goes: dropping both sides erased near objects one or two internal pixels wide (fingers at half
// resolution), and the far side alone keeps the sparse map about as accurate (bench/RESULTS.md).
// `scratch` is resized on first use.
void discontinuity_check(ImageView<std::int16_t> disparity, int max_jump,
                         Image<std::int16_t>& scratch);

// Drops islands of at most max_size pixels whose 4-neighbours step by at most max_diff (the
// islands of cv::filterSpeckles, found without flooding the large ones): wrong matches that
// survived the checks. Keeps its work area across frames.
class SpeckleFilter {
 public:
  SpeckleFilter();
  ~SpeckleFilter();
  SpeckleFilter(SpeckleFilter&&) noexcept;
  SpeckleFilter& operator=(SpeckleFilter&&) noexcept;
  void apply(ImageView<std::int16_t> disparity, int max_size, int max_diff);

 private:
  struct Buffer;
  std::unique_ptr<Buffer> buffer_;
};

// Equiangular (V) fit through the costs at d-1, d, d+1: the offset of its tip, in [-0.5, 0.5].
using kernels::pixel::subpixel_offset;

}  // namespace dco::stereo
