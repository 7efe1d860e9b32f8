#pragma once

// How many pixels of a disparity map hold a value within 1 px of the ground truth: the matches a
// stage got right, for tests that compare a stage with and without a step.

#include <cmath>

#include "dco/core/image.hpp"

namespace dco::testing {

inline int good_matches(const Image<float>& disparity, const Image<float>& truth) {
  int n = 0;
  for (int y = 0; y < truth.height(); ++y)
    for (int x = 0; x < truth.width(); ++x) {
      const float d = disparity.view().at(x, y);
      n += std::isfinite(d) && std::abs(d - truth.view().at(x, y)) <= 1.0f;
    }
  return n;
}

}  // namespace dco::testing
