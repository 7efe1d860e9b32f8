#include "dco/pipeline/stereo/disparity_search.hpp"

#include <algorithm>

#include "dco/kernels/stereo_kernels.hpp"

namespace dco::stereo {

void DisparitySearch::run(const MatchingImages& images, const CostTables& tables,
                          const SupportRegions& regions, int passes, int max_d,
                          WinnerTakesAll& wta) {
  if (passes == 1) {
    run_fused(images, tables, regions, max_d, wta);
    return;
  }
  slice_.resize(images.left.width, images.left.height);
  scratch_.resize(images.left.width, images.left.height);
  for (int d = 0; d <= max_d; ++d) {
    compute_cost_slice_packed(images.left, images.right, images.census_left, images.census_right,
                              images.shortest_arm, tables, d, slice_.view());
    aggregate_costs(slice_.view(), regions, passes, scratch_);
    wta.update(slice_.cview(), d);
  }
}

void DisparitySearch::run_fused(const MatchingImages& images, const CostTables& tables,
                                const SupportRegions& regions, int max_d, WinnerTakesAll& wta) {
  const int w = images.left.width;
  aggregator_.prepare(regions.arms(), kBatch);
  lines_.resize(w, kBatch);
  const kernels::CostTableView wide = tables.wide();
  const ImageView<const std::uint32_t> recip = regions.reciprocals(PassOrder::kHorizontalFirst);
  for (int d0 = 0; d0 <= max_d; d0 += kBatch) {
    // Always whole batches, so the kernels run on whole vectors; disparities past max_d are
    // aggregated but never reach the winner-takes-all state.
    const int count = std::min(kBatch, max_d - d0 + 1);
    const auto cost_sums = [&](int y, std::uint32_t* prefix) {
      const kernels::CostRow row{images.left.row(y),         images.right.row(y),
                                 images.census_left.row(y),  images.census_right.row(y),
                                 images.shortest_arm.row(y), w};
      kernels::block_matching_cost_sums_row(row, wide, d0, kBatch, prefix);
    };
    // Each row's region means go straight into the winner-takes-all state.
    const auto select = [&](int y, std::uint32_t* means) {
      kernels::blocks_to_rows(means, w, kBatch, count, lines_.data(), lines_.stride());
      wta.update_row(lines_.row(0), lines_.stride(), count, y, d0);
    };
    aggregator_.run<true>(kBatch, cost_sums, select, recip);
  }
}

}  // namespace dco::stereo
