#include "dco/pipeline/stereo/cross_arms.hpp"

#include <algorithm>
#include <cassert>
#include <cstdlib>
#include <string>

#include "dco/core/error.hpp"
#include "dco/kernels/stereo_kernels.hpp"
#include "dco/kernels/stereo_pixel.hpp"

namespace dco::stereo {
namespace {

inline int colour_diff(const std::uint8_t* a, const std::uint8_t* b, int channels) {
  int d = std::abs(int(a[0]) - int(b[0]));
  for (int c = 1; c < channels; ++c) d = std::max(d, std::abs(int(a[c]) - int(b[c])));
  return d;
}

// Length of the arm from `anchor` along `step` (in elements), limited to `limit` pixels.
inline int arm_length(const std::uint8_t* anchor, std::ptrdiff_t step, int limit, int channels,
                      const ArmRule& rule) {
  const std::uint8_t* prev = anchor;
  int len = 0;
  for (int i = 1; i <= limit; ++i) {
    const std::uint8_t* q = anchor + step * i;
    const int to_anchor = colour_diff(q, anchor, channels);
    if (to_anchor >= rule.tau1 || colour_diff(q, prev, channels) >= rule.tau1) break;
    if (i > rule.arm_short && to_anchor >= rule.tau2) break;
    len = i;
    prev = q;
  }
  return len;
}

// 3-tap median along one axis (`along_x`: within rows, else within columns), border pixels
// repeated. `tmp` receives a copy of the input.
void median3(Image<std::uint8_t>& img, Image<std::uint8_t>& tmp, bool along_x) {
  tmp.copy_from(img.cview());
  const int w = img.width();
  const int h = img.height();
  const auto median = [](int a, int b, int c) {
    return static_cast<std::uint8_t>(kernels::pixel::median3(a, b, c));
  };
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* mid = tmp.row(y);
    std::uint8_t* out = img.row(y);
    if (along_x) {
      // Plain loops over the interior (vectorised by the compiler), the ends apart.
      out[0] = median(mid[0], mid[0], mid[std::min(1, w - 1)]);
      for (int x = 1; x < w - 1; ++x) out[x] = median(mid[x], mid[x - 1], mid[x + 1]);
      if (w > 1) out[w - 1] = median(mid[w - 1], mid[w - 2], mid[w - 1]);
    } else {
      const std::uint8_t* before = tmp.row(std::max(y - 1, 0));
      const std::uint8_t* after = tmp.row(std::min(y + 1, h - 1));
      for (int x = 0; x < w; ++x) out[x] = median(mid[x], before[x], after[x]);
    }
  }
}

// out[x] = the least of the four arms at x; restrict pointers, so that the compiler vectorises it.
void least_of_four(const std::uint8_t* __restrict left, const std::uint8_t* __restrict right,
                   const std::uint8_t* __restrict up, const std::uint8_t* __restrict down, int n,
                   std::uint8_t* __restrict out) {
  for (int x = 0; x < n; ++x)
    out[x] = std::min(std::min(left[x], right[x]), std::min(up[x], down[x]));
}

}  // namespace

void CrossArms::resize(int width, int height) {
  left.resize(width, height);
  right.resize(width, height);
  up.resize(width, height);
  down.resize(width, height);
}

void compute_cross_arms(ImageView<const std::uint8_t> image, const ArmRule& rule, CrossArms& arms) {
  assert(rule.arm_max >= 0 && rule.arm_max <= 255);
  const int w = image.width;
  const int h = image.height;
  const int ch = image.channels;
  arms.resize(w, h);
  arms.arm_max = rule.arm_max;
  const std::ptrdiff_t down_step = image.stride;
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* row = image.row(y);
    for (int x = 0; x < w; ++x) {
      const std::uint8_t* p = row + x * ch;
      arms.left.at(x, y) =
          static_cast<std::uint8_t>(arm_length(p, -ch, std::min(rule.arm_max, x), ch, rule));
      arms.right.at(x, y) =
          static_cast<std::uint8_t>(arm_length(p, ch, std::min(rule.arm_max, w - 1 - x), ch, rule));
      arms.up.at(x, y) =
          static_cast<std::uint8_t>(arm_length(p, -down_step, std::min(rule.arm_max, y), ch, rule));
      arms.down.at(x, y) = static_cast<std::uint8_t>(
          arm_length(p, down_step, std::min(rule.arm_max, h - 1 - y), ch, rule));
    }
  }
}

void compute_cross_arms(ImageView<const std::uint32_t> packed, const ArmRule& rule,
                        CrossArms& arms) {
  assert(rule.arm_max >= 0 && rule.arm_max <= 255);
  arms.resize(packed.width, packed.height);
  arms.arm_max = rule.arm_max;
  const kernels::ArmParams params{rule.arm_max, rule.arm_short, rule.tau1, rule.tau2};
  for (int y = 0; y < packed.height; ++y)
    kernels::cross_arms_row(packed.data, packed.stride, packed.width, packed.height, y, params,
                            arms.left.row(y), arms.right.row(y), arms.up.row(y), arms.down.row(y));
}

void compute_grey_cross_arms(ImageView<const std::uint8_t> grey, const ArmRule& rule,
                             CrossArms& arms) {
  assert(rule.arm_max >= 0 && rule.arm_max <= 255);
  if (grey.channels != 1)
    throw Error("compute_grey_cross_arms: the image has " + std::to_string(grey.channels) +
                " channels, not 1");
  arms.resize(grey.width, grey.height);
  arms.arm_max = rule.arm_max;
  const kernels::ArmParams params{rule.arm_max, rule.arm_short, rule.tau1, rule.tau2};
  for (int y = 0; y < grey.height; ++y)
    kernels::grey_cross_arms_row(grey.data, grey.stride, grey.width, grey.height, y, params,
                                 arms.left.row(y), arms.right.row(y), arms.up.row(y),
                                 arms.down.row(y));
}

void smooth_cross_arms(CrossArms& arms, Image<std::uint8_t>& scratch) {
  scratch.resize(arms.width(), arms.height());
  // Horizontal arms are smoothed down the columns, vertical arms along the rows. A neighbour's
  // arm never leaves the image at this pixel's position, so the result stays in bounds.
  median3(arms.left, scratch, /*along_x=*/false);
  median3(arms.right, scratch, false);
  median3(arms.up, scratch, /*along_x=*/true);
  median3(arms.down, scratch, true);
}

void shortest_arm_row(const CrossArms& arms, int y, std::uint8_t* out) {
  least_of_four(arms.left.row(y), arms.right.row(y), arms.up.row(y), arms.down.row(y), arms.width(),
                out);
}

}  // namespace dco::stereo
