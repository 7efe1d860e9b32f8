#include "dco/pipeline/contour/stereo_cue.hpp"

#include <algorithm>
#include <cassert>

#include "dco/kernels/contour_pixel.hpp"
#include "dco/pipeline/contour/separable_filters.hpp"

namespace dco::contour {

void disparity_jump_strength(ImageView<const float> disparity, float full_jump,
                             ImageView<float> strength) {
  assert(disparity.channels == 1 && strength.same_size(disparity) && full_jump > 0);
  const int w = disparity.width;
  const int h = disparity.height;
  const float inv = 1.0f / full_jump;
  for (int y = 0; y < h; ++y) {
    // Outside the image the neighbour is the pixel itself: a jump of 0.
    const float* up = disparity.row(std::max(y - 1, 0));
    const float* mid = disparity.row(y);
    const float* down = disparity.row(std::min(y + 1, h - 1));
    float* s = strength.row(y);
    // The first and last columns clamp their neighbours; the interior needs no clamp (vectorises).
    const auto at = [&](int x, int left, int right) {
      return kernels::pixel::jump_strength(mid[x], mid[left], mid[right], up[x], down[x], inv);
    };
    s[0] = at(0, 0, std::min(1, w - 1));
    for (int x = 1; x < w - 1; ++x) s[x] = at(x, x - 1, x + 1);
    if (w > 1) s[w - 1] = at(w - 1, w - 2, w - 1);
  }
}

void stereo_cue(ImageView<const float> disparity, float full_jump, int box_size,
                StereoCueScratch& scratch, Image<float>& cue) {
  const int w = disparity.width, h = disparity.height;
  scratch.jumps.resize(w, h);
  scratch.tmp.resize(w, h);
  cue.resize(w, h);
  disparity_jump_strength(disparity, full_jump, scratch.jumps.view());
  box_filter(scratch.jumps.cview(), box_size, scratch.tmp.view(), cue.view());
}

}  // namespace dco::contour
