#pragma once

#include "dco/core/image.hpp"

// The stereo cue of the depth-contour filter: a stereo pair is a horizontal motion of the camera,
// so jumps of the disparity mark depth contours even when nothing in the scene moves.
namespace dco::contour {

// J(p) = the largest |d(q) - d(p)| over the 4-neighbours q with a finite disparity (0 where d(p)
// itself is not finite), strength = min(J / full_jump, 1). `disparity` and `strength` share a
// size; full_jump > 0.
void disparity_jump_strength(ImageView<const float> disparity, float full_jump,
                             ImageView<float> strength);

// Working memory of stereo_cue, sized on first use.
struct StereoCueScratch {
  Image<float> jumps, tmp;
};

// The stereo cue of a disparity map: disparity_jump_strength, then the box filter of box_size
// that widens it as the flow cue is widened (§5.2). Resizes `cue` to the map's size (allocating
// only when it grows).
void stereo_cue(ImageView<const float> disparity, float full_jump, int box_size,
                StereoCueScratch& scratch, Image<float>& cue);

}  // namespace dco::contour
