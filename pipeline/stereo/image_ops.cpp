#include "dco/pipeline/stereo/image_ops.hpp"

#include <cassert>

namespace dco::stereo {

void downsample_half(ImageView<const std::uint8_t> in, ImageView<std::uint8_t> out) {
  assert(out.width == in.width / 2 && out.height == in.height / 2 && out.channels == in.channels);
  const int ch = in.channels;
  for (int y = 0; y < out.height; ++y) {
    const std::uint8_t* a = in.row(2 * y);
    const std::uint8_t* b = in.row(2 * y + 1);
    std::uint8_t* dst = out.row(y);
    for (int x = 0; x < out.width; ++x)
      for (int c = 0; c < ch; ++c) {
        const int i = 2 * x * ch + c;
        dst[x * ch + c] = static_cast<std::uint8_t>((a[i] + a[i + ch] + b[i] + b[i + ch] + 2) >> 2);
      }
  }
}

void bgr_to_gray(ImageView<const std::uint8_t> bgr, ImageView<std::uint8_t> gray) {
  assert(bgr.channels == 3 && gray.channels == 1 && gray.same_size(bgr));
  constexpr int kB = 3735, kG = 19235, kR = 9798;  // round(w * 2^15), summing to 2^15
  for (int y = 0; y < bgr.height; ++y) {
    const std::uint8_t* s = bgr.row(y);
    std::uint8_t* d = gray.row(y);
    for (int x = 0; x < bgr.width; ++x)
      d[x] = static_cast<std::uint8_t>(
          (s[3 * x] * kB + s[3 * x + 1] * kG + s[3 * x + 2] * kR + (1 << 14)) >> 15);
  }
}

}  // namespace dco::stereo
