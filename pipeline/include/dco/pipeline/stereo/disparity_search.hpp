#pragma once

#include <cstdint>
#include <vector>

#include "dco/core/image.hpp"
#include "dco/pipeline/stereo/cross_aggregation.hpp"
#include "dco/pipeline/stereo/disparity_selection.hpp"
#include "dco/pipeline/stereo/matching_cost.hpp"
#include "dco/pipeline/stereo/search_guide.hpp"

namespace dco::pipeline {
class RowTeam;
}

namespace dco::stereo {

// What the matching cost reads, at the internal resolution.
struct MatchingImages {
  ImageView<const std::uint32_t> left, right;  // AD images, kernels::pack_pixels
  ImageView<const std::uint64_t> census_left, census_right;
  ImageView<const std::uint8_t> shortest_arm;  // L_min, clamped to the tables' max_arm
};

// Cost (Eq. 1), aggregation (Eq. 2) and winner-takes-all (Eq. 3) over disparities 0 .. max_d.
// The result equals, bit for bit, compute_cost_slice + aggregate_costs + WinnerTakesAll::update
// per disparity. With one aggregation pass the stages are fused row by row over kBatch
// disparities at a time, aggregated with the disparities innermost: every disparity of a pixel
// shares its arms, so the sums are contiguous vector loads instead of per-pixel gathers.
//
// With a mask, the pixels of row y in tile t consider only the batches mask.searches(y, t, b): the
// winner-takes-all state is that of the full search with every other cost left out
// (WinnerTakesAll::skip_columns). The fused path searches a batch in windows: each tile's runs
// of searched rows (joined across gaps shorter than the vertical arms' reach), neighbouring
// tiles with the same run sharing one; it computes costs only for the rows and columns a
// window's regions reach.
//
// With a team the fused path gives each of its threads a band of rows: a band aggregates from
// the rows its vertical arms reach above it (those rows' costs are computed twice), and every
// row's winner-takes-all state sees the same costs in the same order, so the result is the same.
class DisparitySearch {
 public:
  // `wta` must be reset to the images' size; `mask`, when given, covers the images' rows and
  // columns and every batch up to max_d.
  void run(const MatchingImages& images, const CostTables& tables, const SupportRegions& regions,
           int passes, int max_d, WinnerTakesAll& wta, const BatchMask* mask = nullptr,
           pipeline::RowTeam* team = nullptr);

  static constexpr int kBatch = 16;

 private:
  // Rows [y_begin, y_end) of tiles [t_begin, t_end) searched together.
  struct Window {
    int y_begin, y_end, t_begin, t_end;
  };
  // One thread's share of the fused search: its aggregator, its rows of a batch's means, and the
  // batch's windows.
  struct Band {
    BlockAggregator aggregator;
    Image<std::uint16_t> lines;  // one row per disparity of the batch
    std::vector<Window> windows;
    std::vector<int> open, next_open;    // windows of the tile before, of this tile
    std::vector<std::uint64_t> covered;  // per row of the band, the tiles its windows cover
  };
  void search_band(const MatchingImages& images, const CostTables& tables,
                   const SupportRegions& regions, int max_d, WinnerTakesAll& wta,
                   const BatchMask* mask, Band& band, int y_begin, int y_end);

  std::vector<Band> bands_;
  Image<std::uint32_t> slice_;
  AggregationScratch scratch_;
};

}  // namespace dco::stereo
