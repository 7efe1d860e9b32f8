#include "dco/pipeline/stereo/cross_aggregation.hpp"

#include <algorithm>
#include <cassert>
#include <cstdint>

#include "dco/kernels/stereo_kernels.hpp"

namespace dco::stereo {

void horizontal_sums(ImageView<const std::uint32_t> in, ImageView<const std::uint8_t> left,
                     ImageView<const std::uint8_t> right, ImageView<std::uint32_t> out,
                     std::vector<std::uint32_t>& prefix) {
  prefix.resize(static_cast<std::size_t>(in.width) + 1);
  for (int y = 0; y < in.height; ++y)
    kernels::horizontal_sums_row(in.row(y), left.row(y), right.row(y), in.width, prefix.data(),
                                 out.row(y));
}

void vertical_sums(ImageView<std::uint32_t> in, ImageView<const std::uint8_t> up,
                   ImageView<const std::uint8_t> down, ImageView<std::uint32_t> out) {
  // The kernel indexes the running sums with 32-bit offsets.
  assert(static_cast<std::int64_t>(in.height) * in.stride <= INT32_MAX);
  for (int y = 1; y < in.height; ++y) kernels::accumulate_row(in.row(y - 1), in.row(y), in.width);
  for (int y = 0; y < in.height; ++y)
    kernels::vertical_sums_row(in.data, in.stride, y, up.row(y), down.row(y), in.width, out.row(y));
}

void AggregationScratch::resize(int width, int height) {
  tmp.resize(width, height);
  prefix.resize(static_cast<std::size_t>(width) + 1);
}

void SupportRegions::build(const CrossArms& arms, AggregationScratch& scratch, int passes) {
  arms_ = &arms;
  const int w = arms.width();
  const int h = arms.height();
  scratch.resize(w, h);
  for (auto* size : {&size_hv_, &size_vh_}) size->resize(w, h);
  recip_hv_.resize(w, h);
  recip_vh_.resize(w, h);
  vertical_first_built_ = passes >= 2;
  for (PassOrder order : {PassOrder::kHorizontalFirst, PassOrder::kVerticalFirst}) {
    if (order == PassOrder::kVerticalFirst && !vertical_first_built_) break;
    Image<std::uint32_t>& size = order == PassOrder::kHorizontalFirst ? size_hv_ : size_vh_;
    Image<std::uint32_t>& recip = order == PassOrder::kHorizontalFirst ? recip_hv_ : recip_vh_;
    size.fill(1);
    sum(size.view(), order, scratch);
    static_assert(kReciprocalShift == 31, "pixel::reciprocal rounds 2^31 / n");
    for (int y = 0; y < h; ++y) kernels::region_reciprocal_row(size.row(y), w, recip.row(y));
  }
}

void SupportRegions::sum(ImageView<std::uint32_t> slice, PassOrder order,
                         AggregationScratch& scratch) const {
  assert(arms_ != nullptr && slice.same_size(arms_->width(), arms_->height()));
  ImageView<std::uint32_t> tmp = scratch.tmp.view();
  if (order == PassOrder::kHorizontalFirst) {
    horizontal_sums(slice, arms_->left.view(), arms_->right.view(), tmp, scratch.prefix);
    vertical_sums(tmp, arms_->up.view(), arms_->down.view(), slice);
  } else {
    vertical_sums(slice, arms_->up.view(), arms_->down.view(), tmp);
    horizontal_sums(tmp, arms_->left.view(), arms_->right.view(), slice, scratch.prefix);
  }
}

void SupportRegions::mean(ImageView<std::uint32_t> slice, PassOrder order,
                          AggregationScratch& scratch) const {
  sum(slice, order, scratch);
  assert(order == PassOrder::kHorizontalFirst || vertical_first_built_);
  const Image<std::uint32_t>& recip = order == PassOrder::kHorizontalFirst ? recip_hv_ : recip_vh_;
  static_assert(kReciprocalShift == 31, "the mean kernel rounds with a shift of 31");
  for (int y = 0; y < slice.height; ++y)
    kernels::region_mean_row(slice.row(y), recip.row(y), slice.width);
}

void BlockAggregator::prepare(const CrossArms& arms, int max_block) {
  arms_ = &arms;
  const int w = arms.width();
  const int h = arms.height();
  reach_up_ = 0;
  reach_down_ = 0;
  reach_left_ = 0;
  reach_right_ = 0;
  const auto longest = [w](const std::uint8_t* row) {
    return int(*std::max_element(row, row + w));
  };
  for (int y = 0; y < h; ++y) {
    reach_up_ = std::max(reach_up_, longest(arms.up.row(y)));
    reach_down_ = std::max(reach_down_, longest(arms.down.row(y)));
    reach_left_ = std::max(reach_left_, longest(arms.left.row(y)));
    reach_right_ = std::max(reach_right_, longest(arms.right.row(y)));
  }
  // Rows y - up - 1 .. y + down must be alive when row y is taken. The first resize takes room
  // for the longest arms the rule allows, so a frame whose arms reach further than the last does
  // not allocate; the second sets the rows in use, since rows wrap at the ring's height and a
  // shorter ring stays in cache.
  ring_.resize(w * max_block, std::min(h, 2 * arms.arm_max + 2));
  ring_.resize(w * max_block, std::min(h, reach_up_ + reach_down_ + 2));
  rows_.resize(static_cast<std::size_t>(h));
  const auto n = static_cast<std::size_t>(w) * static_cast<std::size_t>(max_block);
  input_.resize(n);
  sums_.resize(n);
  zeros_.assign(n, 0);
  prefix_.resize(n + static_cast<std::size_t>(max_block));
}

void aggregate_costs(ImageView<std::uint32_t> slice, const SupportRegions& regions, int passes,
                     AggregationScratch& scratch) {
  for (int i = 0; i < passes; ++i)
    regions.mean(slice, i % 2 == 0 ? PassOrder::kHorizontalFirst : PassOrder::kVerticalFirst,
                 scratch);
}

}  // namespace dco::stereo
