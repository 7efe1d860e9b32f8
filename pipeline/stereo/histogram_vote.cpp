#include "dco/pipeline/stereo/histogram_vote.hpp"

#include <cassert>
#include <cstdlib>

#include "dco/pipeline/stereo/disparity_selection.hpp"

namespace dco::stereo {

void VoteScratch::resize(int width, int height) {
  slice.resize(width, height);
  total.resize(width, height);
  best_votes.resize(width, height);
  best_disp.resize(width, height);
  aggregation.resize(width, height);
}

void histogram_vote(ImageView<std::int16_t> disparity, int max_disparity,
                    const SupportRegions& regions, const VoteRule& rule, VoteScratch& scratch,
                    ImageView<std::uint8_t> changed) {
  const int w = disparity.width;
  const int h = disparity.height;
  scratch.resize(w, h);
  if (!changed.empty())
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) changed.row(y)[x] = 0;

  for (int it = 0; it < rule.iterations; ++it) {
    // How often each disparity occurs: empty bins need no pass.
    scratch.bins.assign(static_cast<std::size_t>(max_disparity) + 1, 0);
    std::uint32_t any = 0;
    for (int y = 0; y < h; ++y) {
      const std::int16_t* d = disparity.row(y);
      std::uint32_t* t = scratch.total.row(y);
      for (int x = 0; x < w; ++x) {
        // Only disparities of the searched range vote (values outside it cannot come from WTA).
        t[x] = d[x] >= 0 && d[x] <= max_disparity;
        if (t[x]) ++scratch.bins[static_cast<std::size_t>(d[x])];
        any += t[x];
      }
    }
    if (any == 0) return;
    regions.sum(scratch.total.view(), PassOrder::kHorizontalFirst, scratch.aggregation);
    scratch.best_votes.fill(0);
    scratch.best_disp.fill(kInvalidDisparity);

    for (int cand = 0; cand <= max_disparity; ++cand) {
      if (scratch.bins[static_cast<std::size_t>(cand)] == 0) continue;
      for (int y = 0; y < h; ++y) {
        const std::int16_t* d = disparity.row(y);
        std::uint32_t* s = scratch.slice.row(y);
        for (int x = 0; x < w; ++x) s[x] = d[x] == cand;
      }
      regions.sum(scratch.slice.view(), PassOrder::kHorizontalFirst, scratch.aggregation);
      for (int y = 0; y < h; ++y) {
        const std::uint32_t* s = scratch.slice.row(y);
        std::uint32_t* bv = scratch.best_votes.row(y);
        std::int16_t* bd = scratch.best_disp.row(y);
        for (int x = 0; x < w; ++x)
          if (s[x] > bv[x]) {
            bv[x] = s[x];
            bd[x] = static_cast<std::int16_t>(cand);
          }
      }
    }

    for (int y = 0; y < h; ++y) {
      std::int16_t* d = disparity.row(y);
      const std::uint32_t* t = scratch.total.row(y);
      const std::uint32_t* bv = scratch.best_votes.row(y);
      const std::int16_t* bd = scratch.best_disp.row(y);
      std::uint8_t* ch = changed.empty() ? nullptr : changed.row(y);
      for (int x = 0; x < w; ++x) {
        const bool decided =
            t[x] >= static_cast<std::uint32_t>(rule.min_count) &&
            static_cast<double>(bv[x]) >= rule.min_ratio * static_cast<double>(t[x]);
        if (!decided) continue;
        if (d[x] == kInvalidDisparity && !rule.fill_invalid) continue;
        if (d[x] != kInvalidDisparity && std::abs(bd[x] - d[x]) <= rule.tolerance) continue;
        if (bd[x] != d[x]) {
          d[x] = bd[x];
          if (ch) ch[x] = 1;
        }
      }
    }
  }
}

}  // namespace dco::stereo
