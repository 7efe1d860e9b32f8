#include "dco/pipeline/stereo/search_guide.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "dco/core/error.hpp"

namespace dco::stereo {

void BatchMask::reset(int height, int batches, bool all) {
  height_ = height;
  batches_ = batches;
  bits_.assign(static_cast<std::size_t>(height) * static_cast<std::size_t>(batches), all ? 1 : 0);
}

double BatchMask::searched_fraction() const {
  if (bits_.empty()) return 0;
  const auto on = std::accumulate(bits_.begin(), bits_.end(), std::size_t{0});
  return static_cast<double>(on) / static_cast<double>(bits_.size());
}

void guide_batches(ImageView<const float> coarse, int height, int max_d, const GuideRule& rule,
                   GuideScratch& scratch, BatchMask& mask) {
  if (coarse.empty() || height <= 0 || max_d < 0 || rule.batch <= 0 || rule.margin < 0 ||
      rule.reach < 0)
    throw Error("search guide: empty coarse map or bad rule");
  const int batches = max_d / rule.batch + 1;
  const int ch = coarse.height;
  // Per coarse row: which batches its values reach, and how many values it has; as running sums
  // over the rows, so each internal row's window is two lookups.
  std::vector<int>& reached = scratch.reached;
  std::vector<int>& valid = scratch.valid;
  std::vector<std::uint8_t>& row_bits = scratch.row_bits;
  reached.assign(static_cast<std::size_t>(batches) * (ch + 1), 0);
  valid.assign(static_cast<std::size_t>(ch) + 1, 0);
  row_bits.resize(static_cast<std::size_t>(batches));
  for (int cy = 0; cy < ch; ++cy) {
    std::fill(row_bits.begin(), row_bits.end(), 0);
    int count = 0;
    const float* v = coarse.row(cy);
    for (int x = 0; x < coarse.width; ++x) {
      if (!std::isfinite(v[x]) || v[x] < 0) continue;
      ++count;
      const int lo = std::clamp(static_cast<int>(std::floor(2.0f * v[x])) - rule.margin, 0, max_d);
      const int hi = std::clamp(static_cast<int>(std::ceil(2.0f * v[x])) + rule.margin, 0, max_d);
      for (int b = lo / rule.batch; b <= hi / rule.batch; ++b) row_bits[b] = 1;
    }
    valid[cy + 1] = valid[cy] + count;
    for (int b = 0; b < batches; ++b)
      reached[static_cast<std::size_t>(b) * (ch + 1) + cy + 1] =
          reached[static_cast<std::size_t>(b) * (ch + 1) + cy] + row_bits[b];
  }
  mask.reset(height, batches, false);
  const int coarse_reach = (rule.reach + 1) / 2;
  for (int y = 0; y < height; ++y) {
    const int centre = std::min(y / 2, ch - 1);
    const int top = std::max(0, centre - coarse_reach);
    const int bottom = std::min(ch, centre + coarse_reach + 1);  // coarse rows [top, bottom)
    const double needed = rule.min_valid * (bottom - top) * coarse.width;
    const bool all = valid[bottom] - valid[top] < needed;
    for (int b = 0; b < batches; ++b) {
      const std::size_t base = static_cast<std::size_t>(b) * (ch + 1);
      if (all || reached[base + bottom] > reached[base + top]) mask.set(y, b);
    }
  }
}

}  // namespace dco::stereo
