#pragma once

// Bit-for-bit comparison of two images (size, channels and every pixel byte; row padding
// ignored), for tests that require identical output rather than close output.

#include <cstring>

#include "dco/core/image.hpp"

namespace dco::testing {

template <typename T>
bool same_bytes(ImageView<const T> a, ImageView<const T> b) {
  if (!a.same_size(b) || a.channels != b.channels) return false;
  for (int y = 0; y < a.height; ++y)
    if (std::memcmp(a.row(y), b.row(y), sizeof(T) * a.width * a.channels) != 0) return false;
  return true;
}

template <typename T>
bool same_bytes(const Image<T>& a, const Image<T>& b) {
  return same_bytes(a.cview(), b.cview());
}

}  // namespace dco::testing
