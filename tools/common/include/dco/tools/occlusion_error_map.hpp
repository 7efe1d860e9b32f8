#pragma once

#include <cstdint>

#include "dco/core/image.hpp"

// A picture of the occlusion errors against one virtual plane, for a person to look at beside
// the figures: where a prediction puts real surfaces in front of the plane that are behind it (a
// halo that hides virtual content) or behind it that are in front (virtual content showing
// through), inside and outside the band that bandErr counts.
namespace dco::tools {

// Colours (BGR) of occlusion_error_map.
struct ErrorMapColors {
  static constexpr std::uint8_t kFrontMatched[3] = {0, 0, 255};    // halo, the matcher's value
  static constexpr std::uint8_t kFrontFilled[3] = {0, 0, 150};     // halo, a filled value
  static constexpr std::uint8_t kBehindMatched[3] = {255, 64, 0};  // show-through, matched
  static constexpr std::uint8_t kBehindFilled[3] = {150, 40, 0};   // show-through, filled
  static constexpr std::uint8_t kMissing[3] = {0, 200, 220};       // no prediction (wrong)
  static constexpr std::uint8_t kBandRight[3] = {0, 110, 0};       // in the band, right side
};

// A BGR image of the GT's size: the left image in grey at half brightness; over it, the GT
// pixels in the band around the plane's true occlusion boundary (as bandErr counts it) in green
// where the prediction is on the right side, and every GT pixel on the wrong side in red
// (predicted in front) or blue (predicted behind), bright where `matches` has a value and dark
// where the value was filled in (every one is bright when `matches` is empty), and in yellow
// where there is no prediction (wrong, as the metrics count it); outside the band at half
// strength. `left` is 1 (grey) or 3 (BGR)
// channels. Throws dco::Error when a map's size or channel count does not fit the GT's.
Image<std::uint8_t> occlusion_error_map(ImageView<const std::uint8_t> left,
                                        ImageView<const float> prediction,
                                        ImageView<const float> gt, double plane,
                                        ImageView<const float> matches = {});

}  // namespace dco::tools
