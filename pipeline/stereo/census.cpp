#include "dco/pipeline/stereo/census.hpp"

#include <algorithm>
#include <cassert>

namespace dco::stereo {

void census_transform(ImageView<const std::uint8_t> gray, int window_w, int window_h,
                      ImageView<std::uint64_t> out) {
  assert(gray.channels == 1 && out.same_size(gray));
  assert(window_w % 2 == 1 && window_h % 2 == 1 && window_w * window_h - 1 <= 64);
  const int rx = window_w / 2;
  const int ry = window_h / 2;
  const int w = gray.width;
  const int h = gray.height;
  const int inner_begin = std::min(rx, w);
  const int inner_end = std::max(inner_begin, w - rx);
  // One window offset at a time over the whole row, so the inner loop is a plain
  // compare-shift-or over contiguous pixels that the compiler vectorises.
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* centre = gray.row(y);
    std::uint64_t* bits = out.row(y);
    std::fill(bits, bits + w, std::uint64_t{0});
    for (int dy = -ry; dy <= ry; ++dy) {
      const std::uint8_t* src = gray.row(std::clamp(y + dy, 0, h - 1));
      for (int dx = -rx; dx <= rx; ++dx) {
        if (dx == 0 && dy == 0) continue;
        for (int x = 0; x < inner_begin; ++x)
          bits[x] = (bits[x] << 1) | (src[std::clamp(x + dx, 0, w - 1)] < centre[x]);
        const std::uint8_t* shifted = src + dx;
        for (int x = inner_begin; x < inner_end; ++x)
          bits[x] = (bits[x] << 1) | (shifted[x] < centre[x]);
        for (int x = inner_end; x < w; ++x)
          bits[x] = (bits[x] << 1) | (src[std::clamp(x + dx, 0, w - 1)] < centre[x]);
      }
    }
  }
}

}  // namespace dco::stereo
