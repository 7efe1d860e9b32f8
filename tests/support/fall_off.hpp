#pragma once

// An image darkened towards its corners by V = 1 - k r^2 (r = 1 at the half-diagonal), as a lens
// does: for tests of the stereo stage's lens fall-off correction.

#include <cmath>
#include <cstdint>

#include "dco/core/image.hpp"
#include "dco/pipeline/stereo/lens_falloff.hpp"

namespace dco::testing {

inline void fall_off(Image<std::uint8_t>& image, double k) {
  ImageView<std::uint8_t> v = image.view();
  for (int y = 0; y < v.height; ++y)
    for (int x = 0; x < v.width; ++x) {
      const double gain = 1.0 - k * stereo::falloff_radius_squared(v.width, v.height, x, y);
      for (int c = 0; c < v.channels; ++c)
        v.at(x, y, c) = static_cast<std::uint8_t>(std::lround(v.at(x, y, c) * gain));
    }
}

}  // namespace dco::testing
