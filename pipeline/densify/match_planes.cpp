#include "dco/pipeline/densify/match_planes.hpp"

#include <algorithm>
#include <cassert>
#include <cstddef>
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

}  // namespace

void MatchPlaneSmoother::row_moments(ImageView<const float> sparse, int grid_y, float offset,
                                     float* sums) {
  const int n = grid_width_;
  float* one = row_.data();
  float* d = one + n;
  float* dd = d + n;
  const float* s = sparse.row(grid_y * step_);
  float* own = sums + kRowSums * n;
  for (int x = 0; x < n; ++x) own[x] = s[x * step_];
  constexpr float kInfinity = std::numeric_limits<float>::infinity();
  for (int x = 0; x < n; ++x) {  // selects, no branches: vectorised
    const float v = own[x];
    const bool known = (v > 0.0f) & (v < kInfinity);
    const float offset_v = known ? v - offset : 0.0f;
    one[x] = known ? 1.0f : 0.0f;
    d[x] = offset_v;
    dd[x] = offset_v * offset_v;
  }
  kernels::match_plane_row_sums(one, d, dd, n, radius_, sums);
}

void MatchPlaneSmoother::apply(ImageView<const float> sparse, int step, int radius, float max_rms,
                               ImageView<float> out) {
  assert(step >= 1 && radius >= 1 && out.same_size(sparse) && sparse.channels == 1);
  const int w = sparse.width, h = sparse.height;
  step_ = step;
  radius_ = radius;
  grid_width_ = (w + step - 1) / step;
  const int n = grid_width_, grid_height = (h + step - 1) / step;
  const int span = 2 * radius + 1;
  const auto row_size = static_cast<std::size_t>(kRingRows) * static_cast<std::size_t>(n);
  ring_.resize(row_size * static_cast<std::size_t>(span));
  window_.resize(static_cast<std::size_t>(kWindowSums) * static_cast<std::size_t>(n));
  row_.resize(3 * static_cast<std::size_t>(n) + 2 * static_cast<std::size_t>(w));
  window_rows_.resize(static_cast<std::size_t>(span));
  column_.resize(static_cast<std::size_t>(w));
  for (int x = 0; x < w; ++x) column_[static_cast<std::size_t>(x)] = std::min(x / step, n - 1);

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
    return ring_.data() + static_cast<std::size_t>(y % span) * row_size;
  };
  for (int y = 0; y < std::min(radius, grid_height); ++y)
    row_moments(sparse, y, offset, ring_row(y));
  for (int gy = 0; gy < grid_height; ++gy) {
    if (gy + radius < grid_height) row_moments(sparse, gy + radius, offset, ring_row(gy + radius));
    for (int j = -radius; j <= radius; ++j)
      window_rows_[static_cast<std::size_t>(j + radius)] =
          gy + j >= 0 && gy + j < grid_height ? ring_row(gy + j) : nullptr;
    float* sum = window_.data();
    kernels::match_plane_window_sums(window_rows_.data(), radius, n, sum);
    // The plane of every grid pixel; NaN where none is kept.
    const float* grid = ring_row(gy) + kRowSums * n;  // the grid row's own values
    float* plane = row_.data();                       // the row scratch is free again here
    kernels::match_plane_row(sum, grid, n, rule, plane);
    // The block's input pixels that hold the grid value take the plane's (the others were
    // decided apart at the input resolution, or are holes): the grid row spread to the input
    // width first, so the loop over each input row is a plain select. Every input row is
    // written here (the grid's rows cover the image).
    float* plane_wide = row_.data() + n;
    float* own_wide = plane_wide + w;
    for (int x = 0; x < w; ++x) {
      const int gx = column_[static_cast<std::size_t>(x)];
      plane_wide[x] = plane[gx];
      own_wide[x] = grid[gx];
    }
    for (int y = gy * step; y < std::min(gy * step + step, h); ++y) {
      const float* s = sparse.row(y);
      float* o = out.row(y);
      for (int x = 0; x < w; ++x)
        o[x] = (s[x] == own_wide[x]) & (plane_wide[x] == plane_wide[x]) ? plane_wide[x] : s[x];
    }
  }
}

}  // namespace dco::densify
