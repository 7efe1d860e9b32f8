#include "dco/pipeline/contour/separable_filters.hpp"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>

#include "dco/kernels/contour_pixel.hpp"

namespace dco::contour {
namespace {

namespace px = kernels::pixel;

std::array<float, 5> make_gaussian_taps() {
  constexpr double kSigma = 1.4;
  std::array<double, 5> w{};
  double sum = 0;
  for (int i = 0; i < 5; ++i) {
    const double d = i - 2;
    w[i] = std::exp(-d * d / (2 * kSigma * kSigma));
    sum += w[i];
  }
  std::array<float, 5> taps{};
  for (int i = 0; i < 5; ++i) taps[i] = static_cast<float>(w[i] / sum);
  return taps;
}

// Horizontal pass of a symmetric kernel on one row: the interior runs tap by tap over contiguous
// memory (vectorises), only the `radius` columns at each end clamp their reads.
void horizontal_pass(const float* in, int width, const float* taps, int radius, float* out) {
  const int size = 2 * radius + 1;
  const int lo = std::min(radius, width);
  const int hi = std::max(lo, width - radius);
  for (int x = lo; x < hi; ++x) out[x] = 0.0f;
  for (int k = 0; k < size; ++k) {
    const float w = taps[k];
    const float* src = in + k - radius;
    for (int x = lo; x < hi; ++x) out[x] += w * src[x];
  }
  const auto tap = [taps](int k) { return taps[k]; };
  for (int x = 0; x < lo; ++x) out[x] = px::clamped_tap_sum(in, width, x, radius, tap);
  for (int x = hi; x < width; ++x) out[x] = px::clamped_tap_sum(in, width, x, radius, tap);
}

}  // namespace

const std::array<float, 5>& gaussian5_taps() {
  static const std::array<float, 5> taps = make_gaussian_taps();
  return taps;
}

void gaussian_blur_5x5(ImageView<const std::uint8_t> in, ImageView<float> tmp,
                       ImageView<float> out) {
  assert(in.channels == 1 && tmp.same_size(in) && out.same_size(in));
  const std::array<float, 5>& taps = gaussian5_taps();
  const int w = in.width;
  const int h = in.height;
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* r0 = in.row(std::max(y - 2, 0));
    const std::uint8_t* r1 = in.row(std::max(y - 1, 0));
    const std::uint8_t* r2 = in.row(y);
    const std::uint8_t* r3 = in.row(std::min(y + 1, h - 1));
    const std::uint8_t* r4 = in.row(std::min(y + 2, h - 1));
    float* t = tmp.row(y);
    for (int x = 0; x < w; ++x)
      t[x] = px::gaussian5_vertical(r0[x], r1[x], r2[x], r3[x], r4[x], taps.data());
  }
  for (int y = 0; y < h; ++y) horizontal_pass(tmp.row(y), w, taps.data(), 2, out.row(y));
}

void box_filter(ImageView<const float> in, int size, ImageView<float> tmp, ImageView<float> out) {
  assert(size >= 1 && size % 2 == 1 && in.channels == 1);
  assert(tmp.same_size(in) && out.same_size(in));
  constexpr int kMaxSize = 255;
  assert(size <= kMaxSize);
  const int radius = size / 2;
  const int w = in.width;
  const int h = in.height;
  const float inv = 1.0f / static_cast<float>(size);
  // Vertical: every output row sums `size` clamped input rows, each add running along the row.
  for (int y = 0; y < h; ++y) {
    float* t = tmp.row(y);
    const float* first = in.row(std::clamp(y - radius, 0, h - 1));
    for (int x = 0; x < w; ++x) t[x] = first[x];
    for (int k = 1; k < size; ++k) {
      const float* r = in.row(std::clamp(y - radius + k, 0, h - 1));
      for (int x = 0; x < w; ++x) t[x] += r[x];
    }
    for (int x = 0; x < w; ++x) t[x] *= inv;
  }
  std::array<float, kMaxSize> taps{};
  for (int k = 0; k < size; ++k) taps[k] = inv;
  for (int y = 0; y < h; ++y) horizontal_pass(tmp.row(y), w, taps.data(), radius, out.row(y));
}

}  // namespace dco::contour
