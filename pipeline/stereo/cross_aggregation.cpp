#include "dco/pipeline/stereo/cross_aggregation.hpp"

#include <cassert>

namespace dco::stereo {

void horizontal_sums(ImageView<const std::uint32_t> in, ImageView<const std::uint8_t> left,
                     ImageView<const std::uint8_t> right, ImageView<std::uint32_t> out,
                     std::vector<std::uint32_t>& prefix) {
  const int w = in.width;
  prefix.resize(static_cast<std::size_t>(w) + 1);
  std::uint32_t* p = prefix.data();
  for (int y = 0; y < in.height; ++y) {
    const std::uint32_t* src = in.row(y);
    p[0] = 0;
    for (int x = 0; x < w; ++x) p[x + 1] = p[x] + src[x];
    const std::uint8_t* l = left.row(y);
    const std::uint8_t* r = right.row(y);
    std::uint32_t* dst = out.row(y);
    for (int x = 0; x < w; ++x) dst[x] = p[x + r[x] + 1] - p[x - l[x]];
  }
}

void vertical_sums(ImageView<std::uint32_t> in, ImageView<const std::uint8_t> up,
                   ImageView<const std::uint8_t> down, ImageView<std::uint32_t> out) {
  const int w = in.width;
  for (int y = 1; y < in.height; ++y) {
    const std::uint32_t* above = in.row(y - 1);
    std::uint32_t* row = in.row(y);
    for (int x = 0; x < w; ++x) row[x] += above[x];
  }
  for (int y = 0; y < in.height; ++y) {
    const std::uint8_t* u = up.row(y);
    const std::uint8_t* d = down.row(y);
    std::uint32_t* dst = out.row(y);
    for (int x = 0; x < w; ++x) {
      const int top = y - u[x] - 1;
      const std::uint32_t below_sum = in.row(y + d[x])[x];
      dst[x] = top >= 0 ? below_sum - in.row(top)[x] : below_sum;
    }
  }
}

void AggregationScratch::resize(int width, int height) {
  tmp.resize(width, height);
  prefix.resize(static_cast<std::size_t>(width) + 1);
}

void SupportRegions::build(const CrossArms& arms, AggregationScratch& scratch) {
  arms_ = &arms;
  const int w = arms.width();
  const int h = arms.height();
  scratch.resize(w, h);
  for (auto* size : {&size_hv_, &size_vh_}) size->resize(w, h);
  recip_hv_.resize(w, h);
  recip_vh_.resize(w, h);
  for (PassOrder order : {PassOrder::kHorizontalFirst, PassOrder::kVerticalFirst}) {
    Image<std::uint32_t>& size = order == PassOrder::kHorizontalFirst ? size_hv_ : size_vh_;
    Image<std::uint32_t>& recip = order == PassOrder::kHorizontalFirst ? recip_hv_ : recip_vh_;
    size.fill(1);
    sum(size.view(), order, scratch);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const std::uint64_t n = size.at(x, y);
        recip.at(x, y) =
            static_cast<std::uint32_t>(((std::uint64_t{1} << kReciprocalShift) + n / 2) / n);
      }
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
  const Image<std::uint32_t>& recip = order == PassOrder::kHorizontalFirst ? recip_hv_ : recip_vh_;
  constexpr std::uint64_t kHalf = std::uint64_t{1} << (kReciprocalShift - 1);
  for (int y = 0; y < slice.height; ++y) {
    std::uint32_t* row = slice.row(y);
    const std::uint32_t* r = recip.row(y);
    for (int x = 0; x < slice.width; ++x)
      row[x] =
          static_cast<std::uint32_t>((std::uint64_t{row[x]} * r[x] + kHalf) >> kReciprocalShift);
  }
}

void aggregate_costs(ImageView<std::uint32_t> slice, const SupportRegions& regions, int passes,
                     AggregationScratch& scratch) {
  for (int i = 0; i < passes; ++i)
    regions.mean(slice, i % 2 == 0 ? PassOrder::kHorizontalFirst : PassOrder::kVerticalFirst,
                 scratch);
}

}  // namespace dco::stereo
