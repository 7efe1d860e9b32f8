#include "dco/pipeline/stereo/search_guide.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "dco/core/error.hpp"

namespace dco::stereo {

void BatchMask::reset(int height, int batches, bool all) {
  height_ = height;
  batches_ = batches;
  width_ = 0;
  tiles_ = 1;
  tile_width_ = std::numeric_limits<int>::max() / 2;
  all_tiles_ = 1;
  bits_.assign(static_cast<std::size_t>(height) * static_cast<std::size_t>(batches),
               all ? all_tiles_ : 0);
}

void BatchMask::reset(int height, int batches, bool all, int width, int tile_width) {
  if (width <= 0 || tile_width <= 0 || (width + tile_width - 1) / tile_width > kMaxTiles)
    throw Error("batch mask: " + std::to_string(width) + " columns need tiles of at least " +
                std::to_string((width + kMaxTiles - 1) / kMaxTiles) + " columns");
  height_ = height;
  batches_ = batches;
  width_ = width;
  tile_width_ = tile_width;
  tiles_ = (width + tile_width - 1) / tile_width;
  all_tiles_ = tiles_bits(0, tiles_);
  bits_.assign(static_cast<std::size_t>(height) * static_cast<std::size_t>(batches),
               all ? all_tiles_ : 0);
}

void BatchMask::merge(const BatchMask& other) {
  if (other.height_ != height_ || other.batches_ != batches_ || other.width_ != width_ ||
      other.tile_width_ != tile_width_)
    throw Error("batch mask: merging masks of different geometry");
  for (std::size_t i = 0; i < bits_.size(); ++i) bits_[i] |= other.bits_[i];
}

double BatchMask::searched_fraction() const {
  if (bits_.empty()) return 0;
  if (width_ == 0) {
    const auto on = std::count_if(bits_.begin(), bits_.end(), [](std::uint64_t b) { return b; });
    return static_cast<double>(on) / static_cast<double>(bits_.size());
  }
  // Every tile but the last is tile_width columns wide.
  const std::uint64_t last = std::uint64_t{1} << (tiles_ - 1);
  const int last_width = width_ - (tiles_ - 1) * tile_width_;
  double columns = 0;
  for (const std::uint64_t b : bits_)
    columns += static_cast<double>(std::popcount(b & ~last)) * tile_width_ +
               ((b & last) != 0 ? last_width : 0);
  return columns / (static_cast<double>(width_) * static_cast<double>(bits_.size()));
}

void guide_batches(ImageView<const float> coarse, int width, int height, int max_d,
                   const GuideRule& rule, GuideScratch& scratch, BatchMask& mask) {
  if (coarse.empty() || width <= 0 || height <= 0 || max_d < 0 || rule.batch <= 0 ||
      rule.margin < 0 || rule.reach < 0 || rule.tile <= 0 || rule.tile_margin < 0 || rule.scale < 1)
    throw Error("search guide: empty coarse map or bad rule");
  const int batches = max_d / rule.batch + 1;
  const int tile = std::max(rule.tile, (width + BatchMask::kMaxTiles - 1) / BatchMask::kMaxTiles);
  const int tiles = (width + tile - 1) / tile;
  const int f = rule.scale;
  const int cw = coarse.width;
  const int ch = coarse.height;
  const auto tile_columns = [&](int t) {  // coarse columns [first, second) a tile takes in
    const int begin = std::max(0, t * tile - rule.tile_margin) / f;
    const int end = std::min(cw, ((t + 1) * tile + rule.tile_margin + f - 1) / f);
    return std::pair{begin, std::max(begin, end)};
  };
  // Per coarse row, per tile and for the whole row: which batches its values reach and how many
  // values it has; as running sums over the rows, so each internal row's window is two lookups.
  const std::size_t rows = static_cast<std::size_t>(ch) + 1;
  std::vector<int>& reached = scratch.reached;  // [(tile * batches + b) * rows + cy]
  std::vector<int>& valid = scratch.valid;      // [tile * rows + cy]
  std::vector<int>& row_reached = scratch.row_reached;
  std::vector<int>& row_valid = scratch.row_valid;
  reached.assign(static_cast<std::size_t>(tiles) * batches * rows, 0);
  valid.assign(static_cast<std::size_t>(tiles) * rows, 0);
  row_reached.assign(static_cast<std::size_t>(batches) * rows, 0);
  row_valid.assign(rows, 0);
  // The batch of each disparity, looked up: a division per value would cost more than the rest
  // of the pass.
  std::vector<int>& batch_of = scratch.batch_of;
  batch_of.resize(static_cast<std::size_t>(max_d) + 1);
  for (int d = 0; d <= max_d; ++d) batch_of[static_cast<std::size_t>(d)] = d / rule.batch;
  // This coarse row's batch range per column, [lo, hi] (lo > hi: no value), made once and read
  // by the row and by every tile that takes the column in.
  std::vector<int>& column_lo = scratch.column_lo;
  std::vector<int>& column_hi = scratch.column_hi;
  column_lo.resize(static_cast<std::size_t>(cw));
  column_hi.resize(static_cast<std::size_t>(cw));
  const auto cap = static_cast<float>(max_d + rule.margin + 1);
  // Per coarse row, the batch ranges of the row's and of each tile's columns as difference
  // arrays (+1 at a range's first batch, -1 past its last): two stores per column whatever
  // its range, and a running sum over the batches gives the bits.
  std::vector<int>& ends =
      scratch.range_ends;  // [(tile or `tiles` for the row) * (batches + 1) + b]
  const std::size_t span = static_cast<std::size_t>(batches) + 1;
  ends.resize(static_cast<std::size_t>(tiles + 1) * span);
  int* row_ends = ends.data() + static_cast<std::size_t>(tiles) * span;
  int* lo_of = column_lo.data();
  int* hi_of = column_hi.data();
  for (int cy = 0; cy < ch; ++cy) {
    std::fill(ends.begin(), ends.end(), 0);
    const float* v = coarse.row(cy);
    int row_count = 0;
    for (int x = 0; x < cw; ++x) {
      int lo = 1, hi = 0;
      if (std::isfinite(v[x]) && v[x] >= 0) {
        // A value past `cap` reaches max_d at both ends, as the cap does, which keeps the
        // conversions in range.
        const float scaled = static_cast<float>(f) * std::min(v[x], cap);
        lo = batch_of[static_cast<std::size_t>(
            std::clamp(static_cast<int>(std::floor(scaled)) - rule.margin, 0, max_d))];
        hi = batch_of[static_cast<std::size_t>(
            std::clamp(static_cast<int>(std::ceil(scaled)) + rule.margin, 0, max_d))];
        ++row_count;
        ++row_ends[lo];
        --row_ends[hi + 1];
      }
      lo_of[x] = lo;
      hi_of[x] = hi;
    }
    row_valid[cy + 1] = row_valid[cy] + row_count;
    for (int b = 0, open = 0; b < batches; ++b) {
      open += row_ends[b];
      const std::size_t at = static_cast<std::size_t>(b) * rows + cy;
      row_reached[at + 1] = row_reached[at] + (open > 0);
    }
    for (int t = 0; t < tiles; ++t) {
      int* tile_ends = ends.data() + static_cast<std::size_t>(t) * span;
      int count = 0;
      const auto [begin, end] = tile_columns(t);
      for (int x = begin; x < end; ++x) {
        if (lo_of[x] > hi_of[x]) continue;
        ++count;
        ++tile_ends[lo_of[x]];
        --tile_ends[hi_of[x] + 1];
      }
      const std::size_t vat = static_cast<std::size_t>(t) * rows + cy;
      valid[vat + 1] = valid[vat] + count;
      for (int b = 0, open = 0; b < batches; ++b) {
        open += tile_ends[b];
        const std::size_t at = (static_cast<std::size_t>(t) * batches + b) * rows + cy;
        reached[at + 1] = reached[at] + (open > 0);
      }
    }
  }
  mask.reset(height, batches, false, width, tile);
  const int coarse_reach = (rule.reach + f - 1) / f;
  for (int y = 0; y < height; ++y) {
    const int centre = std::min(y / f, ch - 1);
    const int top = std::max(0, centre - coarse_reach);
    const int bottom = std::min(ch, centre + coarse_reach + 1);  // coarse rows [top, bottom)
    const auto window = [&](const std::vector<int>& sums, std::size_t base) {
      return sums[base + bottom] - sums[base + top];
    };
    const bool row_all = window(row_valid, 0) < rule.min_valid * (bottom - top) * cw;
    for (int b = 0; b < batches; ++b) {
      const bool row_searches =
          row_all || window(row_reached, static_cast<std::size_t>(b) * rows) > 0;
      for (int t = 0; t < tiles; ++t) {
        const auto [begin, end] = tile_columns(t);
        const bool few = end == begin || window(valid, static_cast<std::size_t>(t) * rows) <
                                             rule.tile_min_valid * (bottom - top) * (end - begin);
        const bool on =
            few ? row_searches
                : window(reached, (static_cast<std::size_t>(t) * batches + b) * rows) > 0;
        if (on) mask.set(y, t, b);
      }
    }
  }
}

void halve_sparse_map(ImageView<const float> map, ImageView<float> half) {
  if (half.width != map.width / 2 || half.height != map.height / 2)
    throw Error("search guide: a halved map of " + std::to_string(map.width) + "x" +
                std::to_string(map.height) + " is " + std::to_string(map.width / 2) + "x" +
                std::to_string(map.height / 2) + ", not " + std::to_string(half.width) + "x" +
                std::to_string(half.height));
  // On the bits: a finite float v >= 0 is below the bits of +inf as an unsigned number (NaN,
  // infinities and negative values are not), and its bits order as its values do. Each usable
  // value becomes its bits + 1, any other 0, and the block keeps the largest. Masks instead of
  // branches, so that the compiler vectorises the row.
  constexpr std::uint32_t kInfinityBits = 0x7f800000u;
  const auto key = [](float v) {
    const auto bits = std::bit_cast<std::uint32_t>(v);
    return (bits + 1) & (0u - static_cast<std::uint32_t>(bits < kInfinityBits));
  };
  for (int y = 0; y < half.height; ++y) {
    const float* __restrict a = map.row(2 * y);
    const float* __restrict b = map.row(2 * y + 1);
    float* __restrict out = half.row(y);
    for (int x = 0; x < half.width; ++x) {
      const std::uint32_t best = std::max(std::max(key(a[2 * x]), key(a[2 * x + 1])),
                                          std::max(key(b[2 * x]), key(b[2 * x + 1])));
      // Halved whatever `best` is (a NaN when 0), then that or +inf by the mask.
      const auto halved = std::bit_cast<std::uint32_t>(0.5f * std::bit_cast<float>(best - 1));
      const std::uint32_t found = 0u - static_cast<std::uint32_t>(best != 0);
      out[x] = std::bit_cast<float>((halved & found) | (kInfinityBits & ~found));
    }
  }
}

}  // namespace dco::stereo
