#pragma once

#include <cstdint>
#include <vector>

#include "dco/core/image.hpp"
#include "dco/kernels/stereo_kernels.hpp"

namespace dco::stereo {

// The AD-census cost of Eq. 1 in fixed point: kCostScale stands for a cost of 1. Both terms are
// looked up in tables indexed by the shortest arm L_min (which fixes α) and by the AD sum or the
// Hamming distance, so the per-pixel work is two lookups and an add, and the result is exact
// integer arithmetic that a SIMD or GPU version can reproduce bit for bit.
inline constexpr std::uint32_t kCostScale = 4096;

// The paper's values; the stereo stage builds its model from StereoParams, whose λ_census
// differs (stereo_params.hpp).
struct CostModel {
  double lambda_ad = 10.0;
  double lambda_census = 40.0;
  double gamma_l = 1.0;
  double epsilon = 0.8;
};

// α of Eq. 1 for a shortest arm length.
double ad_weight(const CostModel& model, int shortest_arm);

class CostTables {
 public:
  // channels: of the AD image (C_AD is the mean absolute difference over them);
  // max_arm: the largest L_min that can occur.
  void build(const CostModel& model, int channels, int max_arm);

  const std::uint16_t* ad_row(int shortest_arm) const {
    return ad_.data() + static_cast<std::size_t>(shortest_arm) * ad_size_;
  }
  const std::uint16_t* census_row(int shortest_arm) const {
    return census_.data() + static_cast<std::size_t>(shortest_arm) * kCensusSize;
  }
  int channels() const { return channels_; }
  int max_arm() const { return max_arm_; }
  // Both tables widened to 32 bits (the SIMD kernel gathers 32-bit lanes).
  kernels::CostTableView wide() const;

  static constexpr int kCensusSize = 65;

 private:
  int channels_ = 0;
  int max_arm_ = -1;
  int ad_size_ = 0;
  int ad_flat_from_ = 0;  // every AD row is constant from here on
  std::vector<std::uint16_t> ad_;
  std::vector<std::uint16_t> census_;
  std::vector<std::uint32_t> wide_ad_, wide_census_;
};

// Cost of matching every left pixel x with right pixel x - d (plain scalar code: the reference
// that the SIMD paths are tested against). Pixels with x < d have no partner
// and get kCostScale, the largest cost. Images at the internal resolution; `shortest_arm` holds
// L_min per pixel, already clamped to the tables' max_arm.
void compute_cost_slice(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                        ImageView<const std::uint64_t> census_left,
                        ImageView<const std::uint64_t> census_right,
                        ImageView<const std::uint8_t> shortest_arm, const CostTables& tables, int d,
                        ImageView<std::uint32_t> out);

// compute_cost_slice on pixels packed by kernels::pack_pixels, with the SIMD kernel: the same
// output, bit for bit.
void compute_cost_slice_packed(ImageView<const std::uint32_t> left,
                               ImageView<const std::uint32_t> right,
                               ImageView<const std::uint64_t> census_left,
                               ImageView<const std::uint64_t> census_right,
                               ImageView<const std::uint8_t> shortest_arm, const CostTables& tables,
                               int d, ImageView<std::uint32_t> out);

}  // namespace dco::stereo
