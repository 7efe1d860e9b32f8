#include "dco/pipeline/stereo/image_ops.hpp"

#include <cassert>

#include "dco/kernels/stereo_kernels.hpp"
#include "dco/kernels/stereo_pixel.hpp"

namespace dco::stereo {
void downsample_half(ImageView<const std::uint8_t> in, ImageView<std::uint8_t> out) {
  assert(out.width == in.width / 2 && out.height == in.height / 2 && out.channels == in.channels);
  const int ch = in.channels;
  for (int y = 0; y < out.height; ++y) {
    const std::uint8_t* a = in.row(2 * y);
    const std::uint8_t* b = in.row(2 * y + 1);
    std::uint8_t* dst = out.row(y);
    if (ch == 1) {  // grey (the headset camera)
      kernels::half_means_row(a, b, out.width, dst);
      continue;
    }
    for (int x = 0; x < out.width; ++x)
      for (int c = 0; c < ch; ++c) {
        const int i = 2 * x * ch + c;
        dst[x * ch + c] = kernels::pixel::half_mean(a[i], a[i + ch], b[i], b[i + ch]);
      }
  }
}

void bgr_to_gray(ImageView<const std::uint8_t> bgr, ImageView<std::uint8_t> gray) {
  assert(bgr.channels == 3 && gray.channels == 1 && gray.same_size(bgr));
  for (int y = 0; y < bgr.height; ++y) {
    const std::uint8_t* s = bgr.row(y);
    std::uint8_t* d = gray.row(y);
    for (int x = 0; x < bgr.width; ++x)
      d[x] = kernels::pixel::grey_of_bgr(s[3 * x], s[3 * x + 1], s[3 * x + 2]);
  }
}

}  // namespace dco::stereo
