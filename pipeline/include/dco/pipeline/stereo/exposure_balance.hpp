#pragma once

#include <array>
#include <cstdint>

#include "dco/core/image.hpp"

namespace dco::stereo {

// The grey-level map that brings one channel of the right camera to the left's: a right value v
// is matched as gain * v + offset. The two cameras of a cheap stereo pair run their own gain and
// black level, and the AD term of Eq. 1 and the arms' thresholds compare raw grey levels across
// the pair: 5 % of gain between the eyes costs the dense map 2.6 points of bad-2 on the shared
// scenes (bench/RESULTS.md, "Exposure balance between the two cameras").
struct ChannelLevels {
  double gain = 1.0;
  double offset = 0.0;
  bool operator==(const ChannelLevels&) const = default;
};

struct ExposureMap {
  std::array<ChannelLevels, 3> channels{};
  int count = 1;  // channels in use: 1 (grey) or 3 (BGR)
  bool operator==(const ExposureMap&) const = default;
};

// The map that changes no level, over `count` channels.
inline ExposureMap no_exposure_map(int count) {
  ExposureMap m;
  m.count = count;
  return m;
}

// Fits the map from the pairs a disparity map gives: matched left pixels (16,384 looked at, four
// times as many when those give too few pairs) against the right image at x - d, per channel,
// where both lie on flat ground along their rows (the pixel and its row neighbours within 6
// levels) and neither is saturated (0 or 255). The mean right level at each left level, a line
// through those means weighted by their counts, then once more without the means more than 3
// levels off it.
// Returns false, leaving `map` as it was, with fewer than kMinExposurePairs pairs, left levels
// spread over fewer than 16, or a gain outside [0.5, 2]: a frame that cannot tell.
inline constexpr int kMinExposurePairs = 500;
bool fit_exposure(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                  ImageView<const float> disparity, ExposureMap& map);

// The largest difference between the two maps' rounded tables, in grey levels.
int exposure_difference(const ExposureMap& a, const ExposureMap& b);

// A map's rounded lookup table, and the right image through it.
class ExposureTable {
 public:
  void build(const ExposureMap& map);
  bool identity() const { return identity_; }
  // Writes `right` through the table into `out` (resized to it).
  void apply(ImageView<const std::uint8_t> right, Image<std::uint8_t>& out) const;

 private:
  std::array<std::array<std::uint8_t, 256>, 3> table_{};
  int count_ = 1;
  bool identity_ = true;
};

}  // namespace dco::stereo
