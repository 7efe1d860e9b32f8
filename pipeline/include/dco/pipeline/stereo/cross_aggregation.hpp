#pragma once

#include <cstdint>
#include <vector>

#include "dco/core/image.hpp"
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
  void build(const CrossArms& arms, AggregationScratch& scratch);

  const CrossArms& arms() const { return *arms_; }
  // Unnormalised region sum, in place: slice(p) = sum over the region of p.
  void sum(ImageView<std::uint32_t> slice, PassOrder order, AggregationScratch& scratch) const;
  // Region mean, in place, rounded to the nearest integer (Eq. 2).
  void mean(ImageView<std::uint32_t> slice, PassOrder order, AggregationScratch& scratch) const;
  // Region sizes (pixels) for a pass order.
  ImageView<const std::uint32_t> sizes(PassOrder order) const {
    return order == PassOrder::kHorizontalFirst ? size_hv_.view() : size_vh_.view();
  }

  // mean = (sum * reciprocal + 2^30) >> 31, reciprocal = round(2^31 / size).
  static constexpr int kReciprocalShift = 31;

 private:
  const CrossArms* arms_ = nullptr;
  Image<std::uint32_t> size_hv_, size_vh_;
  Image<std::uint32_t> recip_hv_, recip_vh_;
};

// Eq. 2 over `passes` alternating passes (horizontal-first, then vertical-first, ...), each
// producing the region mean that the next pass aggregates again.
void aggregate_costs(ImageView<std::uint32_t> slice, const SupportRegions& regions, int passes,
                     AggregationScratch& scratch);

}  // namespace dco::stereo
