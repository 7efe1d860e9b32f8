#include "dco/pipeline/stereo/disparity_search.hpp"

#include <algorithm>

#include "dco/core/error.hpp"
#include "dco/kernels/stereo_kernels.hpp"
#include "dco/pipeline/row_team.hpp"

namespace dco::stereo {
namespace {

// The first column of tile t, clipped to the image's width (a one-tile mask's tiles are wider
// than any image).
int tile_column(int t, int tile_width, int width) {
  return static_cast<int>(std::min<std::int64_t>(width, std::int64_t{t} * tile_width));
}

// Calls f(x_begin, x_end, on) for the runs of tiles [t_begin, t_end) of a row's bits that all
// search (on) or all do not, left to right, in columns clipped to the image's width.
template <class F>
void for_each_tile_run(std::uint64_t bits, int t_begin, int t_end, int tile_width, int width,
                       F&& f) {
  for (int t = t_begin; t < t_end;) {
    const bool on = (bits >> t) & 1u;
    int end = t + 1;
    while (end < t_end && (((bits >> end) & 1u) != 0) == on) ++end;
    const int x0 = tile_column(t, tile_width, width), x1 = tile_column(end, tile_width, width);
    if (x0 < x1) f(x0, x1, on);
    t = end;
  }
}

}  // namespace

void DisparitySearch::run(const MatchingImages& images, const CostTables& tables,
                          const SupportRegions& regions, int passes, int max_d, WinnerTakesAll& wta,
                          const BatchMask* mask, pipeline::RowTeam* team) {
  const int w = images.left.width;
  const int h = images.left.height;
  if (mask != nullptr && (mask->height() != h || mask->batches() * kBatch <= max_d ||
                          static_cast<std::int64_t>(mask->tiles()) * mask->tile_width() < w))
    throw Error("disparity search: the batch mask does not cover the image and disparities");
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
  slice_.resize(w, h);
  scratch_.resize(w, h);
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
    for (int y = 0; y < h; ++y)
      for_each_tile_run(mask->tile_bits(y, batch), 0, mask->tiles(), mask->tile_width(), w,
                        [&](int x0, int x1, bool on) {
                          if (on)
                            wta.update_slice_columns(slice_.row(y), y, d, x0, x1);
                          else
                            wta.skip_columns(y, d, 1, x0, x1);
                        });
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
  band.covered.resize(static_cast<std::size_t>(y_end - y_begin));
  // A tile has at most one run of rows per two rows: reserved once, so no frame allocates.
  const std::size_t runs = static_cast<std::size_t>(y_end - y_begin) / 2 + 1;
  band.open.reserve(runs);
  band.next_open.reserve(runs);
  const kernels::CostTableView wide = tables.wide();
  const ImageView<const std::uint32_t> recip = regions.reciprocals(PassOrder::kHorizontalFirst);
  // Rows of one tile closer than this are searched in one run: the rows between cost no more
  // than the second run's own start-up rows would.
  const int join_rows = aggregator.reach_up() + aggregator.reach_down();
  const int tiles = mask != nullptr ? mask->tiles() : 1;
  const int tile_width = mask != nullptr ? mask->tile_width() : w;
  const std::uint64_t all_tiles = BatchMask::tiles_bits(0, tiles);
  band.windows.reserve(static_cast<std::size_t>(tiles) * runs);
  for (int d0 = 0; d0 <= max_d; d0 += kBatch) {
    // Always whole batches, so the kernels run on whole vectors; disparities past max_d are
    // aggregated but never reach the winner-takes-all state.
    const int count = std::min(kBatch, max_d - d0 + 1);
    const int batch = d0 / kBatch;
    const auto tile_bits = [&](int y) {
      return mask != nullptr ? mask->tile_bits(y, batch) : all_tiles;
    };
    // Windows of rows and tiles: each tile's runs of searched rows, joined across short gaps,
    // a run shared by neighbouring tiles in one window. Made tile by tile, so any row meets its
    // windows left to right, as the right image's state needs.
    std::vector<Window>& windows = band.windows;
    std::vector<int>& open = band.open;
    std::vector<int>& next_open = band.next_open;
    windows.clear();
    open.clear();
    for (int t = 0; t < tiles; ++t) {
      next_open.clear();
      int y = y_begin;
      while (y < y_end) {
        if (((tile_bits(y) >> t) & 1u) == 0) {
          ++y;
          continue;
        }
        int end = y + 1;
        for (int gap = 0; end + gap < y_end && gap <= join_rows;) {
          if (((tile_bits(end + gap) >> t) & 1u) != 0) {
            end += gap + 1;
            gap = 0;
          } else {
            ++gap;
          }
        }
        int found = -1;
        for (const int i : open)
          if (windows[i].y_begin == y && windows[i].y_end == end) found = i;
        if (found >= 0) {
          windows[found].t_end = t + 1;
        } else {
          found = static_cast<int>(windows.size());
          windows.push_back({y, end, t, t + 1});
        }
        next_open.push_back(found);
        y = end;
      }
      open.swap(next_open);
    }
    const auto cost_sums = [&](int y, std::uint32_t* prefix, int x_begin, int x_end) {
      const kernels::CostRow row{images.left.row(y),         images.right.row(y),
                                 images.census_left.row(y),  images.census_right.row(y),
                                 images.shortest_arm.row(y), w};
      kernels::block_matching_cost_sums_range(row, wide, d0, kBatch, x_begin, x_end, prefix);
    };
    std::fill(band.covered.begin(), band.covered.end(), 0);
    for (const Window& window : windows) {
      const int x_begin = tile_column(window.t_begin, tile_width, w);
      const int x_end = tile_column(window.t_end, tile_width, w);
      // Each row's region means go straight into the winner-takes-all state; its tiles that do
      // not search the batch take kNoCost, which leaves the batch out.
      const auto select = [&](int y, std::uint32_t* means) {
        for_each_tile_run(
            tile_bits(y), window.t_begin, window.t_end, tile_width, w,
            [&](int x0, int x1, bool on) {
              if (on) {
                kernels::blocks_to_rows(means + static_cast<std::ptrdiff_t>(x0) * kBatch, x1 - x0,
                                        kBatch, count, band.lines.data() + x0, band.lines.stride());
                return;
              }
              for (int k = 0; k < count; ++k)
                std::fill(band.lines.row(k) + x0, band.lines.row(k) + x1, WinnerTakesAll::kNoCost);
            });
        wta.update_columns(band.lines.row(0), band.lines.stride(), count, y, d0, x_begin, x_end);
      };
      aggregator.run_window(kBatch, window.y_begin, window.y_end, x_begin, x_end, cost_sums, select,
                            recip);
      const std::uint64_t window_tiles = BatchMask::tiles_bits(window.t_begin, window.t_end);
      for (int y = window.y_begin; y < window.y_end; ++y)
        band.covered[static_cast<std::size_t>(y - y_begin)] |= window_tiles;
    }
    // Every tile of a row outside its windows leaves the batch out.
    for (int y = y_begin; y < y_end; ++y) {
      const std::uint64_t rest = all_tiles & ~band.covered[static_cast<std::size_t>(y - y_begin)];
      for_each_tile_run(rest, 0, tiles, tile_width, w, [&](int x0, int x1, bool on) {
        if (on) wta.skip_columns(y, d0, count, x0, x1);
      });
    }
  }
}

}  // namespace dco::stereo
