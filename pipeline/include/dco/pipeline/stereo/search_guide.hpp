#pragma once

#include <cstdint>
#include <vector>

#include "dco/core/image.hpp"

namespace dco::stereo {

// Which batches of kBatch disparities (batch b: b * kBatch .. b * kBatch + kBatch - 1) each row of
// the internal image searches.
class BatchMask {
 public:
  // Every row searches every batch (all) or none.
  void reset(int height, int batches, bool all);
  int height() const { return height_; }
  int batches() const { return batches_; }
  bool searches(int y, int batch) const {
    return bits_[static_cast<std::size_t>(batch) * height_ + y] != 0;
  }
  void set(int y, int batch) { bits_[static_cast<std::size_t>(batch) * height_ + y] = 1; }
  // Share of the (row, batch) pairs searched, in [0, 1].
  double searched_fraction() const;

 private:
  int height_ = 0, batches_ = 0;
  std::vector<std::uint8_t> bits_;  // [batch * height + y]
};

// How far the guide reaches (internal pixels and rows).
struct GuideRule {
  int batch = 16;          // disparities per batch
  int margin = 12;         // a coarse value v lets its row search 2v - margin .. 2v + margin
  int reach = 8;           // internal rows above and below whose coarse values a row takes in
  double min_valid = 0.2;  // fewer coarse values than this share of the rows reached: search all
};

// Working memory of guide_batches.
struct GuideScratch {
  std::vector<int> reached, valid;
  std::vector<std::uint8_t> row_bits;
};

// From the sparse map of a half-size pass over the internal images (coarse pixels, +inf or NaN
// where it has no value): each internal row searches the batches holding the disparities 2v ±
// margin of every coarse value v within `reach` rows of it, or every batch when too few coarse
// values are there to go by. max_d: the largest internal disparity searched. `scratch` is resized
// on first use and kept across frames.
void guide_batches(ImageView<const float> coarse, int height, int max_d, const GuideRule& rule,
                   GuideScratch& scratch, BatchMask& mask);

}  // namespace dco::stereo
