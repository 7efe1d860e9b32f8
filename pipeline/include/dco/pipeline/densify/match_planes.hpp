#pragma once

#include <vector>

#include "dco/core/image.hpp"

namespace dco::densify {

// Smooths the matches of a sparse disparity map along local planes before the densifier reads
// them. A match's sub-pixel noise (a tenth of a pixel and more) moves the crossing of a virtual
// plane with a slanted surface by many pixels from frame to frame; the plane through its
// neighbours' matches does not.
//
// The map is read at the matcher's own grid: every `step`-th pixel of every `step`-th row (its
// values come in step x step blocks when the stereo stage matches at 1/step of the input size).
// A grid match takes the value of the least-squares plane through the grid matches of its
// (2 radius + 1)^2 window, at its own position, where the window holds matches on at least a
// quarter of its area and they lie within max_rms (px, RMS) of that plane; elsewhere (depth
// edges, curved or sparse windows) it keeps its value. The input pixels of its block that hold
// the block's value take the new one; pixels the stage decided apart (the boundary refinement)
// and holes keep theirs.
//
// The window's ten moments come from separable sums over offsets relative to the centre (single
// precision, disparities taken relative to the middle of the frame's range): per grid row every
// window offset over the whole row, then every row offset over a ring of those row sums. Nothing
// is allocated once the buffers fit the width.
class MatchPlaneSmoother {
 public:
  // `out` must have sparse's size and not share its memory.
  void apply(ImageView<const float> sparse, int step, int radius, float max_rms,
             ImageView<float> out);
  // Sizes the buffers apply needs for rows `width` pixels wide, so that a smoother kept ready
  // but not used every frame allocates nothing when it is.
  void reserve(int width, int step, int radius);

 private:
  void row_moments(ImageView<const float> sparse, int grid_y, float offset, float* sums);

  int step_ = 1, radius_ = 1, grid_width_ = 0;
  // Ring of (2 radius + 2) grid rows of six row sums (a window's rows and the one that left it);
  // the ten window sums of a grid row, moved down the grid; a grid row's matches (1 or 0),
  // offset disparities and their squares.
  std::vector<float> ring_, window_, row_;
  std::vector<int> column_;                // grid column of each input column
  std::vector<const float*> window_rows_;  // the ring rows of a window, nullptr outside
};

}  // namespace dco::densify
