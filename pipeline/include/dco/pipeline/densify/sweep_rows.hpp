#pragma once

#include "dco/core/image.hpp"
#include "dco/kernels/densify_kernels.hpp"
#include "dco/pipeline/densify/grid_system.hpp"

namespace dco::densify {

// The rows a pass of red-black Gauss-Seidel sweeps is working on, copied split by column parity
// (kernels::SplitSmoothRow): one colour of a row is then one parity, and every operand of its
// update is a contiguous run instead of every other float, so the sweeps need no shuffles to
// separate the colours. The rows live in a ring of slots: row r in slot r % slots from load(r)
// until row r + slots is loaded.
class SweepRows {
 public:
  // Starts a pass over a system of `width` x `height` with room for `slots` rows at once
  // (clamped to [1, height]). The memory only grows: a pass no larger than an earlier one
  // allocates nothing.
  void start(int width, int height, int slots);

  // Copies row r of x, b and of a's coefficients into row r's slot (1 / diag worked out from
  // diag, by GridSystem's rule: one row fewer to read). Without a.has_diagonal the diagonal row
  // is worked out from data and the weights first, as GridSystem::update_diagonal_rows does.
  void load(const GridSystem& a, ImageView<const float> b, ImageView<const float> x, int r);
  // Updates the pixels of one column parity of row r; the rows next to it must be loaded.
  void smooth(int r, int parity);
  // Copies row r's x back into x.
  void store(int r, ImageView<float> x) const;
  // out = row r of b - A x from the rows in the slots (r and the rows next to it must be loaded),
  // the same bits as densify::residual_row.
  void residual(int r, float* out);
  // A row of `width` floats of the caller's own, kept with the ring.
  float* spare_row() { return spare_.data(); }

 private:
  enum Array { kX, kB, kDiag, kInvDiag, kWx, kWy, kArrays };
  kernels::SplitSmoothRow smooth_row(int r, int parity) const;
  float* array(int r, Array a, int parity);
  const float* array(int r, Array a, int parity) const;

  int width_ = 0, height_ = 0, slots_ = 1;
  int half_ = 0;       // floats of one parity of one array, padded to whole cache lines
  Image<float> ring_;  // one slot per row: kArrays arrays, each its even then its odd pixels
  Image<float> spare_;
  Image<float> diagonal_;  // a diagonal row and its inverse, for a system without its diagonal
  Image<float> residual_;  // a residual row split, before it is merged
};

}  // namespace dco::densify
