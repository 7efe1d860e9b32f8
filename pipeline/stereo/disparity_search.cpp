#include "dco/pipeline/stereo/disparity_search.hpp"

#include <algorithm>

#include "dco/core/error.hpp"
#include "dco/kernels/stereo_kernels.hpp"
#include "dco/pipeline/row_team.hpp"

namespace dco::stereo {

void DisparitySearch::run(const MatchingImages& images, const CostTables& tables,
                          const SupportRegions& regions, int passes, int max_d, WinnerTakesAll& wta,
                          const BatchMask* mask, pipeline::RowTeam* team) {
  if (mask != nullptr &&
      (mask->height() != images.left.height || mask->batches() * kBatch <= max_d))
    throw Error("disparity search: the batch mask does not cover the image rows and disparities");
  const int h = images.left.height;
  if (passes == 1) {
    const int parts = team != nullptr ? team->threads() : 1;
    if (bands_.size() < static_cast<std::size_t>(parts))
      bands_.resize(static_cast<std::size_t>(parts));
    const auto band = [&](int part, int begin, int end) {
      search_band(images, tables, regions, max_d, wta, mask, bands_[static_cast<std::size_t>(part)],
                  begin, end);
    };
    if (team != nullptr)
      team->run(h, band);
    else
      band(0, 0, h);
    return;
  }
  slice_.resize(images.left.width, h);
  scratch_.resize(images.left.width, h);
  for (int d = 0; d <= max_d; ++d) {
    const int batch = d / kBatch;
    if (mask != nullptr) {
      bool any = false;
      for (int y = 0; y < h && !any; ++y) any = mask->searches(y, batch);
      if (!any) {
        for (int y = 0; y < h; ++y) wta.skip_row(y, d, 1);
        continue;
      }
    }
    compute_cost_slice_packed(images.left, images.right, images.census_left, images.census_right,
                              images.shortest_arm, tables, d, slice_.view());
    aggregate_costs(slice_.view(), regions, passes, scratch_);
    if (mask == nullptr) {
      wta.update(slice_.cview(), d);
      continue;
    }
    for (int y = 0; y < h; ++y) {
      if (mask->searches(y, batch))
        wta.update_slice_row(slice_.row(y), y, d);
      else
        wta.skip_row(y, d, 1);
    }
  }
}

void DisparitySearch::search_band(const MatchingImages& images, const CostTables& tables,
                                  const SupportRegions& regions, int max_d, WinnerTakesAll& wta,
                                  const BatchMask* mask, Band& band, int y_begin, int y_end) {
  if (y_begin >= y_end) return;
  const int w = images.left.width;
  BlockAggregator& aggregator = band.aggregator;
  aggregator.prepare(regions.arms(), kBatch);
  band.lines.resize(w, kBatch);
  const kernels::CostTableView wide = tables.wide();
  const ImageView<const std::uint32_t> recip = regions.reciprocals(PassOrder::kHorizontalFirst);
  // Rows closer than this are searched in one run: the rows between cost no more than the
  // second run's own start-up rows would.
  const int join_gap = aggregator.reach_up() + aggregator.reach_down();
  for (int d0 = 0; d0 <= max_d; d0 += kBatch) {
    // Always whole batches, so the kernels run on whole vectors; disparities past max_d are
    // aggregated but never reach the winner-takes-all state.
    const int count = std::min(kBatch, max_d - d0 + 1);
    const int batch = d0 / kBatch;
    const auto searched = [&](int y) { return mask == nullptr || mask->searches(y, batch); };
    const auto cost_sums = [&](int y, std::uint32_t* prefix) {
      const kernels::CostRow row{images.left.row(y),         images.right.row(y),
                                 images.census_left.row(y),  images.census_right.row(y),
                                 images.shortest_arm.row(y), w};
      kernels::block_matching_cost_sums_row(row, wide, d0, kBatch, prefix);
    };
    // Each row's region means go straight into the winner-takes-all state.
    const auto select = [&](int y, std::uint32_t* means) {
      if (!searched(y)) {
        wta.skip_row(y, d0, count);
        return;
      }
      kernels::blocks_to_rows(means, w, kBatch, count, band.lines.data(), band.lines.stride());
      wta.update_row(band.lines.row(0), band.lines.stride(), count, y, d0);
    };
    if (mask == nullptr) {
      aggregator.run_rows<true>(kBatch, y_begin, y_end, cost_sums, select, recip);
      continue;
    }
    // Runs of searched rows, joined across short gaps; rows outside every run skip the batch.
    int y = y_begin;
    while (y < y_end) {
      if (!searched(y)) {
        wta.skip_row(y, d0, count);
        ++y;
        continue;
      }
      int end = y + 1;
      for (int gap = 0; end + gap < y_end && gap <= join_gap;) {
        if (searched(end + gap)) {
          end += gap + 1;
          gap = 0;
        } else {
          ++gap;
        }
      }
      aggregator.run_rows<true>(kBatch, y, end, cost_sums, select, recip);
      y = end;
    }
  }
}

}  // namespace dco::stereo
