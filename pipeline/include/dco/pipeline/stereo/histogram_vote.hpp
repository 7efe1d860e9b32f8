#pragma once

#include <cstdint>
#include <vector>

#include "dco/core/image.hpp"
#include "dco/pipeline/stereo/cross_aggregation.hpp"

namespace dco::stereo {

struct VoteRule {
  int iterations = 2;
  int min_count = 20;         // reliable pixels the region must hold for the vote to count
  double min_ratio = 0.4;     // share of them the winning disparity needs
  int tolerance = 1;          // a reliable pixel this close to the winner keeps its own value
  bool fill_invalid = false;  // a decided vote also gives a value to an unreliable pixel
};

struct VoteScratch {
  Image<std::uint32_t> total, best_votes;
  Image<std::int16_t> best_disp;
  std::vector<std::uint32_t> bins;       // pixels per disparity
  std::vector<std::int32_t> candidates;  // the disparities that occur
  BlockAggregator aggregator;            // kVoteBatch bins at a time
  void resize(int width, int height);
};

inline constexpr int kVoteBatch = 16;

// Iterated histogram vote, Eq. 4: a pixel takes the most frequent disparity among the reliable
// pixels (those not kInvalidDisparity) of its support region when that region holds at least
// min_count of them, the winner has at least min_ratio of the votes, and the pixel's own value
// is more than `tolerance` away from it (on a slanted surface the mode of a large region is not
// every pixel's disparity, so near-agreement keeps the pixel's own, subpixel-refinable value).
// With fill_invalid, unreliable pixels take decided votes too and vote in the next iteration.
// The histogram of every pixel is counted by summing one indicator image per disparity over the
// support regions, kVoteBatch disparities at a time. `changed` (optional) is set to 1 where a
// vote changed the value.
void histogram_vote(ImageView<std::int16_t> disparity, int max_disparity,
                    const SupportRegions& regions, const VoteRule& rule, VoteScratch& scratch,
                    ImageView<std::uint8_t> changed = {});

}  // namespace dco::stereo
