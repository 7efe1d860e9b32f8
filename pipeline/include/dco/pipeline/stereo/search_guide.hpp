#pragma once

#include <cstdint>
#include <vector>

#include "dco/core/image.hpp"

namespace dco::stereo {

// Which batches of kBatch disparities (batch b: b * kBatch .. b * kBatch + kBatch - 1) each row of
// the internal image searches, per tile of columns (tile t: columns t * tile_width ..
// (t + 1) * tile_width - 1).
class BatchMask {
 public:
  static constexpr int kMaxTiles = 64;
  // The bits of tiles [begin, end) (0 <= begin <= end <= kMaxTiles).
  static std::uint64_t tiles_bits(int begin, int end) {
    const auto below = [](int t) {
      return t == 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << t) - 1;
    };
    return below(end) & ~below(begin);
  }

  // Every row searches every batch (all) or none, in one tile that spans any width.
  void reset(int height, int batches, bool all);
  // The same in tiles of tile_width columns over `width` columns (at most kMaxTiles tiles).
  void reset(int height, int batches, bool all, int width, int tile_width);
  int height() const { return height_; }
  int batches() const { return batches_; }
  int tiles() const { return tiles_; }
  int tile_width() const { return tile_width_; }
  // Whether some tile of row y searches the batch.
  bool searches(int y, int batch) const { return tile_bits(y, batch) != 0; }
  bool searches(int y, int tile, int batch) const { return (tile_bits(y, batch) >> tile) & 1u; }
  // Bit t: tile t of row y searches the batch.
  std::uint64_t tile_bits(int y, int batch) const {
    return bits_[static_cast<std::size_t>(batch) * height_ + y];
  }
  // Every tile of row y searches the batch.
  void set(int y, int batch) { bits_[static_cast<std::size_t>(batch) * height_ + y] = all_tiles_; }
  void set(int y, int tile, int batch) {
    bits_[static_cast<std::size_t>(batch) * height_ + y] |= std::uint64_t{1} << tile;
  }
  // Also searches what `other` (of the same geometry) searches.
  void merge(const BatchMask& other);
  // Share of the (row, column, batch) triples searched, in [0, 1].
  double searched_fraction() const;

 private:
  int height_ = 0, batches_ = 0, width_ = 0, tiles_ = 1, tile_width_ = 0;
  std::uint64_t all_tiles_ = 1;
  std::vector<std::uint64_t> bits_;  // [batch * height + y], a bit per tile
};

// How far the guide reaches (internal pixels and rows).
struct GuideRule {
  int batch = 16;   // disparities per batch
  int margin = 12;  // a coarse value v lets its tile search 2v - margin .. 2v + margin
  int reach = 8;    // internal rows above and below whose coarse values a row takes in
  // Columns per tile (widened where a row would need more than BatchMask::kMaxTiles), and the
  // internal columns left and right of a tile whose coarse values it takes in. Narrower tiles
  // search less but each starts its own run of costs, whose arms reach past its edges.
  int tile = 128;
  int tile_margin = 16;
  // A row with fewer coarse values than this share of those it reaches searches every batch; a
  // tile with fewer than tile_min_valid takes its row's batches (below half, tiles missed
  // disparities their rows hold: bench/RESULTS.md).
  double min_valid = 0.2;
  double tile_min_valid = 0.5;
  int scale = 2;  // internal pixels per coarse pixel, across and down (1, 2, 4, ...)
};

// Working memory of guide_batches.
struct GuideScratch {
  std::vector<int> reached, valid, row_reached, row_valid;
  std::vector<int> batch_of, column_lo, column_hi, range_ends;
};

// From a coarse sparse map of the internal images, rule.scale internal pixels per coarse pixel
// across and down (a pass over the internal images halved: 2; +inf or NaN where it has no
// value): each tile of an internal row searches the batches holding the disparities
// scale * v ± margin of every coarse value v within `reach` rows and `tile_margin` columns of it. A
// tile with too few coarse values to go by takes the batches of its whole row's values instead
// (those of every column within `reach` rows), and a row with too few searches every batch. width,
// height: the internal image's size; max_d: the largest internal disparity searched. `scratch` is
// resized on first use and kept across frames.
void guide_batches(ImageView<const float> coarse, int width, int height, int max_d,
                   const GuideRule& rule, GuideScratch& scratch, BatchMask& mask);

// A sparse map of the internal images as a coarse map of rule.scale 2: each 2x2 block's largest
// value (the nearest surface the block holds), halved, +inf where the block has none (values
// are finite floats from +0 up; NaN, infinities and negative values are none); a last odd row
// or column is left out. `half` is (map.width / 2) x (map.height / 2).
void halve_sparse_map(ImageView<const float> map, ImageView<float> half);

}  // namespace dco::stereo
