#pragma once

// Helpers shared by the stereo-stage tests: seeded random images and valid random cross arms.

#include <algorithm>
#include <cstdint>
#include <random>

#include "dco/core/image.hpp"
#include "dco/pipeline/stereo/cross_arms.hpp"

namespace dco::test {

template <typename T>
Image<T> random_image(std::mt19937& rng, int width, int height, int channels, T lo, T hi) {
  Image<T> img(width, height, channels);
  std::uniform_int_distribution<std::uint64_t> dist(lo, hi);
  for (int y = 0; y < height; ++y)
    for (int i = 0; i < width * channels; ++i) img.row(y)[i] = static_cast<T>(dist(rng));
  return img;
}

// Arms that never leave the image and are at most `max_len` long.
inline stereo::CrossArms random_arms(std::mt19937& rng, int width, int height, int max_len) {
  stereo::CrossArms arms;
  arms.resize(width, height);
  std::uniform_int_distribution<int> len(0, max_len);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      arms.left.at(x, y) = static_cast<std::uint8_t>(std::min(len(rng), x));
      arms.right.at(x, y) = static_cast<std::uint8_t>(std::min(len(rng), width - 1 - x));
      arms.up.at(x, y) = static_cast<std::uint8_t>(std::min(len(rng), y));
      arms.down.at(x, y) = static_cast<std::uint8_t>(std::min(len(rng), height - 1 - y));
    }
  return arms;
}

// Arms that reach the image border in every direction: every support region is the whole image.
inline stereo::CrossArms full_arms(int width, int height) {
  stereo::CrossArms arms;
  arms.resize(width, height);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      arms.left.at(x, y) = static_cast<std::uint8_t>(x);
      arms.right.at(x, y) = static_cast<std::uint8_t>(width - 1 - x);
      arms.up.at(x, y) = static_cast<std::uint8_t>(y);
      arms.down.at(x, y) = static_cast<std::uint8_t>(height - 1 - y);
    }
  return arms;
}

}  // namespace dco::test
