#pragma once

#include <cstdint>

#include "dco/core/image.hpp"

namespace dco::stereo {

// Arm lengths of the adaptive cross-support window of every pixel (§4.1). The support region of
// p is built from these: the horizontal arms of every pixel on p's vertical arm (or the reverse).
struct CrossArms {
  Image<std::uint8_t> left, right, up, down;
  int arm_max = 255;  // the rule's longest arm, which no arm exceeds

  void resize(int width, int height);
  int width() const { return left.width(); }
  int height() const { return left.height(); }
};

// AD-census's published values; the stereo stage builds its rule from StereoParams, whose
// defaults differ (stereo_params.hpp).
struct ArmRule {
  int arm_max = 34;    // L1
  int arm_short = 17;  // L2: beyond it the colour must stay within tau2
  int tau1 = 20;
  int tau2 = 6;
};

// Grows each arm from the anchor pixel while (a) the colour difference to the anchor is < tau1,
// (b) the difference between consecutive pixels on the arm is < tau1, (c) past arm_short the
// difference to the anchor is < tau2, and (d) the arm stays inside the image and <= arm_max.
// Colour difference = the largest absolute difference over the channels.
void compute_cross_arms(ImageView<const std::uint8_t> image, const ArmRule& rule, CrossArms& arms);
// The same on pixels packed by kernels::pack_pixels, with the SIMD kernel: equal arms.
void compute_cross_arms(ImageView<const std::uint32_t> packed, const ArmRule& rule,
                        CrossArms& arms);
// The same on a one-channel image with the SIMD kernel on bytes (four times the pixels per
// vector of the packed one): equal arms.
void compute_grey_cross_arms(ImageView<const std::uint8_t> grey, const ArmRule& rule,
                             CrossArms& arms);

// Smooths the window shapes (§4.1): a 3-tap median of each arm length across the arm direction
// (left/right arms over the pixel above and below, up/down arms over the pixels beside it)
// removes single-line spikes and notches, so neighbouring windows have similar shapes.
// `scratch` is resized to the arm size on first use.
void smooth_cross_arms(CrossArms& arms, Image<std::uint8_t>& scratch);

// The shortest of the four arms of every pixel of row y: the L_min of Eq. 1.
void shortest_arm_row(const CrossArms& arms, int y, std::uint8_t* out);

}  // namespace dco::stereo
