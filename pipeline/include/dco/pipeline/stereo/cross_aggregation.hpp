#pragma once

#include <algorithm>
#include <cassert>
#include <cstdint>
#include <vector>

#include "dco/core/image.hpp"
#include "dco/kernels/stereo_kernels.hpp"
#include "dco/pipeline/stereo/cross_arms.hpp"

namespace dco::stereo {

// Sums over cross-based support regions with integral images along one axis at a time
// (orthogonal integral images): a horizontal-first pass gives, for p, the sum over the
// horizontal arms of every pixel on p's vertical arm; a vertical-first pass the transpose.
// All sums are uint32 with wrap-around, which is exact as long as a region's true sum fits
// in 32 bits (costs <= 2^16 over <= 255 x 255 pixels do).

// out(x, y) = sum of in over [x - left(x,y), x + right(x,y)]. `prefix` is a caller-owned row
// buffer (resized to width + 1 on first use).
void horizontal_sums(ImageView<const std::uint32_t> in, ImageView<const std::uint8_t> left,
                     ImageView<const std::uint8_t> right, ImageView<std::uint32_t> out,
                     std::vector<std::uint32_t>& prefix);

// out(x, y) = sum of the original column over [y - up(x,y), y + down(x,y)]. Overwrites `in`
// with its running column sums.
void vertical_sums(ImageView<std::uint32_t> in, ImageView<const std::uint8_t> up,
                   ImageView<const std::uint8_t> down, ImageView<std::uint32_t> out);

// Scratch for one thread's aggregation of one slice at a time.
struct AggregationScratch {
  Image<std::uint32_t> tmp;
  std::vector<std::uint32_t> prefix;
  void resize(int width, int height);
};

enum class PassOrder { kHorizontalFirst, kVerticalFirst };

// Region sizes and their fixed-point reciprocals for both pass orders, built once per frame.
class SupportRegions {
 public:
  // Sizes and reciprocals of the pass orders that `passes` alternating passes use: horizontal
  // first only for one pass, both from two on.
  void build(const CrossArms& arms, AggregationScratch& scratch, int passes = 2);

  const CrossArms& arms() const { return *arms_; }
  // Unnormalised region sum, in place: slice(p) = sum over the region of p.
  void sum(ImageView<std::uint32_t> slice, PassOrder order, AggregationScratch& scratch) const;
  // Region mean, in place, rounded to the nearest integer (Eq. 2).
  void mean(ImageView<std::uint32_t> slice, PassOrder order, AggregationScratch& scratch) const;
  // round(2^31 / region size) per pixel: the region mean is (sum * r + 2^30) >> 31.
  ImageView<const std::uint32_t> reciprocals(PassOrder order) const {
    assert(order == PassOrder::kHorizontalFirst || vertical_first_built_);
    return order == PassOrder::kHorizontalFirst ? recip_hv_.view() : recip_vh_.view();
  }
  // Region sizes (pixels) for a pass order.
  ImageView<const std::uint32_t> sizes(PassOrder order) const {
    assert(order == PassOrder::kHorizontalFirst || vertical_first_built_);
    return order == PassOrder::kHorizontalFirst ? size_hv_.view() : size_vh_.view();
  }

  // mean = (sum * reciprocal + 2^30) >> 31, reciprocal = round(2^31 / size).
  static constexpr int kReciprocalShift = 31;

 private:
  const CrossArms* arms_ = nullptr;
  bool vertical_first_built_ = false;
  Image<std::uint32_t> size_hv_, size_vh_;
  Image<std::uint32_t> recip_hv_, recip_vh_;
};

// Eq. 2 over `passes` alternating passes (horizontal-first, then vertical-first, ...), each
// producing the region mean that the next pass aggregates again.
void aggregate_costs(ImageView<std::uint32_t> slice, const SupportRegions& regions, int passes,
                     AggregationScratch& scratch);

// Horizontal-first region sums of `block` values per pixel (the kernels' block layout: value k
// of pixel x at [x * block + k]), streamed row by row: fill(y, values) writes row y of the
// input, take(y, sums) receives row y of the region sums, in increasing y. Every value of a
// pixel shares its arms, so the sums are whole-vector loads. The running column sums live in a
// ring of rows just tall enough for the vertical arms, so they stay in the caches.
class BlockAggregator {
 public:
  // Once per frame: sizes the buffers for blocks of up to max_block values.
  void prepare(const CrossArms& arms, int max_block);

  // With `reciprocals` (SupportRegions::reciprocals), take receives the region means instead.
  template <class Fill, class Take>
  void run(int block, Fill&& fill, Take&& take, ImageView<const std::uint32_t> reciprocals = {}) {
    run_core<false>(block, 0, arms_->height(), 0, arms_->width(), fill, take, reciprocals);
  }

  // The same for the window of rows [y_begin, y_end) and columns [x_begin, x_end) only, from
  // running sums along the rows: fill(y, prefix, xs, xe) writes those of row y's values over the
  // columns [xs, xe) that the window's horizontal arms reach, starting over at xs (as
  // kernels::block_matching_cost_sums_range does), and is asked for just the rows the window's
  // vertical arms reach. take(y, sums) receives, at the window's columns of sums (indexed by
  // column), exactly what run gives them.
  template <class Fill, class Take>
  void run_window(int block, int y_begin, int y_end, int x_begin, int x_end, Fill&& fill,
                  Take&& take, ImageView<const std::uint32_t> reciprocals = {}) {
    run_core<true>(block, y_begin, y_end, x_begin, x_end, fill, take, reciprocals);
  }

  // Rows above / below a row that its vertical arms reach, at most.
  int reach_up() const { return reach_up_; }
  int reach_down() const { return reach_down_; }
  // Columns left / right of a pixel that its horizontal arms reach, at most.
  int reach_left() const { return reach_left_; }
  int reach_right() const { return reach_right_; }

 private:
  template <bool kFillsPrefix, class Fill, class Take>
  void run_core(int block, int y_begin, int y_end, int x_begin, int x_end, Fill&& fill, Take&& take,
                ImageView<const std::uint32_t> reciprocals) {
    const CrossArms& a = *arms_;
    const int w = a.width();
    const int h = a.height();
    const int first = std::max(0, y_begin - reach_up_);
    const int last = std::min(h, y_end + reach_down_);  // rows filled: [first, last)
    const int xs = std::max(0, x_begin - reach_left_);
    const int xe = std::min(w, x_end + reach_right_);  // columns filled: [xs, xe)
    const int columns = x_end - x_begin;
    // Row pointers start at the window's first column, so the kernels see a narrower image.
    const std::ptrdiff_t offset = static_cast<std::ptrdiff_t>(x_begin) * block;
    for (int i = first; i < last; ++i) rows_[i] = ring_.row(i % ring_.height()) + offset;
    // The running column sums start at `first`: a region whose top is the row above it
    // subtracts nothing.
    if (first > 0) rows_[first - 1] = zeros_.data() + offset;
    for (int ya = first; ya < y_end + reach_down_; ++ya) {
      if (ya < last) {
        // Horizontal sums plus the row above's running column sums.
        const std::uint32_t* above = ya > first ? rows_[ya - 1] : nullptr;
        if constexpr (kFillsPrefix) {
          fill(ya, prefix_.data(), xs, xe);
          kernels::block_window_sums_row(prefix_.data() + offset, a.left.row(ya) + x_begin,
                                         a.right.row(ya) + x_begin, columns, block, above,
                                         rows_[ya]);
        } else {
          fill(ya, input_.data());
          kernels::block_horizontal_sums_row(input_.data(), a.left.row(ya), a.right.row(ya), w,
                                             block, prefix_.data(), above, rows_[ya]);
        }
      }
      // Row yb has all of its vertical arms' rows once row yb + reach_down is in.
      const int yb = ya - reach_down_;
      if (yb < y_begin) continue;
      kernels::block_vertical_sums_row(
          rows_.data(), yb, a.up.row(yb) + x_begin, a.down.row(yb) + x_begin, columns, block,
          reciprocals.empty() ? nullptr : reciprocals.row(yb) + x_begin, sums_.data() + offset);
      take(yb, sums_.data());
    }
  }

  const CrossArms* arms_ = nullptr;
  int reach_up_ = 0, reach_down_ = 0, reach_left_ = 0, reach_right_ = 0;
  Image<std::uint32_t> ring_;
  std::vector<std::uint32_t*> rows_;  // image row -> its ring row
  std::vector<std::uint32_t> input_, prefix_, sums_;
  std::vector<std::uint32_t> zeros_;  // the running sums above a run's first row
};

}  // namespace dco::stereo
