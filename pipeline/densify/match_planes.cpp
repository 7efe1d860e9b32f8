#include "dco/pipeline/densify/match_planes.hpp"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "dco/kernels/densify_kernels.hpp"
#include "dco/kernels/densify_pixel.hpp"

namespace dco::densify {
namespace {

// Row sums of a window row: Σ1, Σu, Σu², Σd, Σud, Σd² over the matches (u = column offset from
// the centre, d = offset disparity).
constexpr int kRowSums = 6;
// Each ring row also holds the grid row's own values.
constexpr int kRingRows = kRowSums + 1;
// Window sums: Σ1, Σu, Σv, Σu², Σuv, Σv², Σd, Σud, Σvd, Σd².
constexpr int kWindowSums = 10;

// out[g] = row[g * step] for g < n; step 2 (half-size matching) written apart so that it
// vectorises.
void grid_row(const float* __restrict row, int n, int step, float* __restrict out) {
  if (step == 2) {
    for (int g = 0; g < n; ++g) out[g] = row[2 * g];
  } else {
    for (int g = 0; g < n; ++g) out[g] = row[g * step];
  }
}

// Per match: 1, its disparity less `offset` and that squared; 0, 0, 0 for a hole. A match is a
// positive finite value, tested on its bits: integer masks let the compiler vectorise the loop,
// where float comparisons (which may trap on NaN) keep a branch per pixel.
void offset_matches(const float* __restrict own, int n, float offset, float* __restrict one,
                    float* __restrict d, float* __restrict dd) {
  constexpr std::int32_t kInfinityBits = 0x7f800000;
  constexpr std::int32_t kOneBits = 0x3f800000;
  for (int x = 0; x < n; ++x) {
    const float v = own[x];
    const auto bits = std::bit_cast<std::int32_t>(v);
    const std::int32_t known = -static_cast<std::int32_t>((bits > 0) & (bits < kInfinityBits));
    const float offset_v = std::bit_cast<float>(std::bit_cast<std::int32_t>(v - offset) & known);
    one[x] = std::bit_cast<float>(kOneBits & known);
    d[x] = offset_v;
    dd[x] = offset_v * offset_v;
  }
}

// out[x] = in[column[x]]: the grid row spread to the input width.
void spread_row(const float* in, const int* column, int width, float* out) {
  for (int x = 0; x < width; ++x) out[x] = in[column[x]];
}

}  // namespace

void MatchPlaneSmoother::row_moments(ImageView<const float> sparse, int grid_y, float offset,
                                     float* sums) {
  const int n = grid_width_;
  float* one = row_.data();
  float* d = one + n;
  float* dd = d + n;
  float* own = sums + kRowSums * n;
  grid_row(sparse.row(grid_y * step_), n, step_, own);
  offset_matches(own, n, offset, one, d, dd);
  kernels::match_plane_row_sums(one, d, dd, n, radius_, sums);
}

void MatchPlaneSmoother::reserve(int width, int step, int radius) {
  assert(width >= 1 && step >= 1 && radius >= 1);
  step_ = step;
  radius_ = radius;
  grid_width_ = (width + step - 1) / step;
  const auto n = static_cast<std::size_t>(grid_width_);
  // The window's rows and the one that just left it (match_plane_window_slide reads it).
  const auto ring = static_cast<std::size_t>(2 * radius + 2);
  ring_.resize(static_cast<std::size_t>(kRingRows) * n * ring);
  window_.resize(static_cast<std::size_t>(kWindowSums) * n);
  row_.resize(3 * n + 2 * static_cast<std::size_t>(width));
  window_rows_.resize(ring - 1);
  column_.resize(static_cast<std::size_t>(width));
  for (int x = 0; x < width; ++x)
    column_[static_cast<std::size_t>(x)] = std::min(x / step, grid_width_ - 1);
}

void MatchPlaneSmoother::apply(ImageView<const float> sparse, int step, int radius, float max_rms,
                               ImageView<float> out) {
  assert(step >= 1 && radius >= 1 && out.same_size(sparse) && sparse.channels == 1);
  const int w = sparse.width, h = sparse.height;
  reserve(w, step, radius);
  const int n = grid_width_, grid_height = (h + step - 1) / step;
  const int span = 2 * radius + 1;
  const auto row_size = static_cast<std::size_t>(kRingRows) * static_cast<std::size_t>(n);

  // Disparities relative to the middle of the range keep Σd² small enough for floats; every
  // eighth grid row tells the range closely enough for that, every row where those have no match.
  float low = std::numeric_limits<float>::infinity(), high = -low;
  for (const int stride : {8 * step, step}) {
    for (int y = 0; y < h; y += stride) {
      const float* s = sparse.row(y);
      for (int x = 0; x < w; x += step)
        if (kernels::pixel::known_value(s[x]))
          low = std::min(low, s[x]), high = std::max(high, s[x]);
    }
    if (high >= low) break;
  }
  if (!(high >= low)) {  // no match on the grid: nothing to smooth
    for (int y = 0; y < h; ++y) std::copy(sparse.row(y), sparse.row(y) + w, out.row(y));
    return;
  }
  const float offset = 0.5f * (low + high);
  const kernels::MatchPlaneRule rule{offset, 0.25f * static_cast<float>(span * span),
                                     max_rms * max_rms};
  const auto ring_row = [&](int y) {
    return ring_.data() + static_cast<std::size_t>(y % (span + 1)) * row_size;
  };
  for (int y = 0; y < std::min(radius, grid_height); ++y)
    row_moments(sparse, y, offset, ring_row(y));
  for (int gy = 0; gy < grid_height; ++gy) {
    if (gy + radius < grid_height) row_moments(sparse, gy + radius, offset, ring_row(gy + radius));
    for (int j = -radius; j <= radius; ++j)
      window_rows_[static_cast<std::size_t>(j + radius)] =
          gy + j >= 0 && gy + j < grid_height ? ring_row(gy + j) : nullptr;
    float* sum = window_.data();
    // The first window's sums from its rows, each next one moved down from the one above.
    if (gy == 0)
      kernels::match_plane_window_sums(window_rows_.data(), radius, n, sum);
    else
      kernels::match_plane_window_slide(window_rows_.data(),
                                        gy - 1 - radius >= 0 ? ring_row(gy - 1 - radius) : nullptr,
                                        radius, n, sum);
    // The plane of every grid pixel; NaN where none is kept.
    const float* grid = ring_row(gy) + kRowSums * n;  // the grid row's own values
    float* plane = row_.data();                       // the row scratch is free again here
    kernels::match_plane_row(sum, grid, n, rule, plane);
    // The block's input pixels that hold the grid value take the plane's (the others were
    // decided apart at the input resolution, or are holes). Every input row is written here
    // (the grid's rows cover the image).
    if (step == 2) {
      for (int y = gy * step; y < std::min(gy * step + step, h); ++y)
        kernels::match_plane_select_half_row(sparse.row(y), grid, plane, w, out.row(y));
      continue;
    }
    // Other steps: the grid row spread to the input width first, so the loop over each input
    // row is a plain select.
    float* plane_wide = row_.data() + n;
    float* own_wide = plane_wide + w;
    spread_row(plane, column_.data(), w, plane_wide);
    spread_row(grid, column_.data(), w, own_wide);
    for (int y = gy * step; y < std::min(gy * step + step, h); ++y) {
      const float* s = sparse.row(y);
      float* o = out.row(y);
      for (int x = 0; x < w; ++x)
        o[x] = kernels::pixel::match_plane_select(s[x], own_wide[x], plane_wide[x]);
    }
  }
}

}  // namespace dco::densify
