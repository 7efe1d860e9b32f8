#include "dco/pipeline/stereo/matching_cost.hpp"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdlib>

namespace dco::stereo {

double ad_weight(const CostModel& model, int shortest_arm) {
  return 1.0 - std::exp(-model.gamma_l / (shortest_arm + model.epsilon));
}

void CostTables::build(const CostModel& model, int channels, int max_arm) {
  channels_ = channels;
  max_arm_ = max_arm;
  ad_size_ = 255 * channels + 1;
  ad_.resize(static_cast<std::size_t>(max_arm + 1) * ad_size_);
  census_.resize(static_cast<std::size_t>(max_arm + 1) * kCensusSize);
  for (int arm = 0; arm <= max_arm; ++arm) {
    const double alpha = ad_weight(model, arm);
    std::uint16_t* ad = ad_.data() + static_cast<std::size_t>(arm) * ad_size_;
    for (int s = 0; s < ad_size_; ++s) {
      const double c_ad = static_cast<double>(s) / channels;
      ad[s] = static_cast<std::uint16_t>(
          std::lround(kCostScale * alpha * (1.0 - std::exp(-c_ad / model.lambda_ad))));
    }
    std::uint16_t* cen = census_.data() + static_cast<std::size_t>(arm) * kCensusSize;
    for (int hd = 0; hd < kCensusSize; ++hd)
      cen[hd] = static_cast<std::uint16_t>(
          std::lround(kCostScale * (1.0 - alpha) * (1.0 - std::exp(-hd / model.lambda_census))));
  }
  ad_flat_from_ = 0;
  for (int arm = 0; arm <= max_arm; ++arm) {
    const std::uint16_t* ad = ad_row(arm);
    int from = ad_size_ - 1;
    while (from > 0 && ad[from - 1] == ad[ad_size_ - 1]) --from;
    ad_flat_from_ = std::max(ad_flat_from_, from);
  }
  wide_ad_.assign(ad_.begin(), ad_.end());
  wide_census_.assign(census_.begin(), census_.end());
}

kernels::CostTableView CostTables::wide() const {
  return {wide_ad_.data(), ad_size_, wide_census_.data(), kCensusSize, kCostScale, ad_flat_from_};
}

void compute_cost_slice(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                        ImageView<const std::uint64_t> census_left,
                        ImageView<const std::uint64_t> census_right,
                        ImageView<const std::uint8_t> shortest_arm, const CostTables& tables, int d,
                        ImageView<std::uint32_t> out) {
  assert(left.channels == tables.channels() && right.channels == left.channels);
  const int w = left.width;
  const int ch = left.channels;
  const int first = d < w ? d : w;
  for (int y = 0; y < left.height; ++y) {
    std::uint32_t* dst = out.row(y);
    const std::uint8_t* l = left.row(y);
    const std::uint8_t* r = right.row(y);
    const std::uint64_t* cl = census_left.row(y);
    const std::uint64_t* cr = census_right.row(y);
    const std::uint8_t* arm = shortest_arm.row(y);
    for (int x = 0; x < first; ++x) dst[x] = kCostScale;
    for (int x = first; x < w; ++x) {
      const std::uint8_t* pl = l + x * ch;
      const std::uint8_t* pr = r + (x - d) * ch;
      int ad = 0;
      for (int c = 0; c < ch; ++c) ad += std::abs(int(pl[c]) - int(pr[c]));
      const int hd = std::popcount(cl[x] ^ cr[x - d]);
      dst[x] = std::uint32_t(tables.ad_row(arm[x])[ad]) + tables.census_row(arm[x])[hd];
    }
  }
}

void compute_cost_slice_packed(ImageView<const std::uint32_t> left,
                               ImageView<const std::uint32_t> right,
                               ImageView<const std::uint64_t> census_left,
                               ImageView<const std::uint64_t> census_right,
                               ImageView<const std::uint8_t> shortest_arm, const CostTables& tables,
                               int d, ImageView<std::uint32_t> out) {
  const kernels::CostTableView wide = tables.wide();
  for (int y = 0; y < left.height; ++y) {
    const kernels::CostRow row{left.row(y),         right.row(y),        census_left.row(y),
                               census_right.row(y), shortest_arm.row(y), left.width};
    kernels::matching_cost_row(row, wide, d, out.row(y));
  }
}

}  // namespace dco::stereo
