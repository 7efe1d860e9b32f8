#include "dco/pipeline/stereo/histogram_vote.hpp"

#include <algorithm>
#include <climits>
#include <cstdlib>

#include "dco/kernels/stereo_kernels.hpp"
#include "dco/kernels/stereo_pixel.hpp"
#include "dco/pipeline/stereo/disparity_selection.hpp"

namespace dco::stereo {

void VoteScratch::resize(int width, int height) {
  total.resize(width, height);
  best_votes.resize(width, height);
  best_disp.resize(width, height);
}

namespace {

constexpr std::int32_t kNoBin = INT32_MIN;

// Adds the region sums of the indicator images of `candidates` to `total` and keeps, per pixel,
// the first candidate with the most votes.
void count_votes(ImageView<const std::int16_t> disparity, const std::int32_t* candidates, int count,
                 VoteScratch& s) {
  const int w = disparity.width;
  const auto indicators = [&](int y, std::uint32_t* blocks) {
    kernels::block_indicator_row(disparity.row(y), w, candidates, count, blocks);
  };
  // Every reliable pixel counts in exactly one bin, so the bins add up to the total.
  const auto tally = [&](int y, std::uint32_t* votes) {
    kernels::block_vote_row(votes, w, candidates, count, s.total.row(y), s.best_votes.row(y),
                            s.best_disp.row(y));
  };
  s.aggregator.run(count, indicators, tally);
}

}  // namespace

void histogram_vote(ImageView<std::int16_t> disparity, int max_disparity,
                    const SupportRegions& regions, const VoteRule& rule, VoteScratch& scratch,
                    ImageView<std::uint8_t> changed) {
  const int w = disparity.width;
  const int h = disparity.height;
  scratch.resize(w, h);
  if (!changed.empty())
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) changed.row(y)[x] = 0;

  const kernels::pixel::VoteParams params{rule.min_count, rule.min_ratio, rule.tolerance,
                                          rule.fill_invalid};
  for (int it = 0; it < rule.iterations; ++it) {
    // How often each disparity occurs: empty bins need no pass. Only disparities of the searched
    // range vote (values outside it cannot come from WTA).
    scratch.bins.assign(static_cast<std::size_t>(max_disparity) + 1, 0);
    for (int y = 0; y < h; ++y) {
      const std::int16_t* d = disparity.row(y);
      for (int x = 0; x < w; ++x)
        if (d[x] >= 0 && d[x] <= max_disparity) ++scratch.bins[static_cast<std::size_t>(d[x])];
    }
    scratch.candidates.clear();
    // Once per geometry: room for every disparity plus the padding below.
    scratch.candidates.reserve(static_cast<std::size_t>(max_disparity) + kVoteBatch);
    for (int cand = 0; cand <= max_disparity; ++cand)
      if (scratch.bins[static_cast<std::size_t>(cand)] > 0) scratch.candidates.push_back(cand);
    if (scratch.candidates.empty()) return;
    // Whole batches keep the kernels on whole vectors. A padding bin matches no 16-bit value, so
    // it holds no votes and never wins (a bin must beat the best strictly).
    while (scratch.candidates.size() % kVoteBatch != 0) scratch.candidates.push_back(kNoBin);
    scratch.total.fill(0);
    scratch.best_votes.fill(0);
    scratch.best_disp.fill(kInvalidDisparity);
    const int n = static_cast<int>(scratch.candidates.size());
    scratch.aggregator.prepare(regions.arms(), kVoteBatch);
    for (int first = 0; first < n; first += kVoteBatch)
      count_votes(disparity, scratch.candidates.data() + first, kVoteBatch, scratch);

    for (int y = 0; y < h; ++y) {
      std::int16_t* d = disparity.row(y);
      const std::uint32_t* t = scratch.total.row(y);
      const std::uint32_t* bv = scratch.best_votes.row(y);
      const std::int16_t* bd = scratch.best_disp.row(y);
      std::uint8_t* ch = changed.empty() ? nullptr : changed.row(y);
      for (int x = 0; x < w; ++x) {
        const std::int16_t v = kernels::pixel::voted_value(d[x], t[x], bv[x], bd[x], params);
        if (v != d[x]) {
          d[x] = v;
          if (ch) ch[x] = 1;
        }
      }
    }
  }
}

}  // namespace dco::stereo
