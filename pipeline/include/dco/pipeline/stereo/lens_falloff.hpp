#pragma once

#include <cstdint>

#include <opencv2/core/mat.hpp>

#include "dco/core/image.hpp"

namespace dco::stereo {

// A lens's fall-off of brightness from the image centre towards the corners (vignetting), shared
// by the two cameras of a pair built from one lens model: V(r) = 1 - k r^2, r = 1 at the
// half-diagonal from the centre ((width - 1) / 2, (height - 1) / 2). A scene point lies at
// another distance from the centre in each view (by its disparity), so the two cameras read it
// at levels that differ by V(r_right) / V(r_left), which the AD term of Eq. 1 and the arms'
// thresholds take for a difference of the scene. The shared scenes' real pairs show k of
// 0.03-0.33 (KITTI's the most); bench/RESULTS.md, "Lens fall-off shared by the two cameras".
struct LensFalloff {
  double k = 0.0;
  bool identity() const { return k == 0.0; }
  bool operator==(const LensFalloff&) const = default;
};

// The fall-off's r^2 at (x, y) of a width x height image.
double falloff_radius_squared(int width, int height, double x, double y);

// Fits k to the pairs a disparity map gives (the flat matched pairs of exposure_balance.hpp's
// fit): right = a left + b - a k u left per channel, u = r^2 at the right pixel - r^2 at the
// left one, by least squares (a pair's gain and black level are fitted with it); k is the
// channels' mean weighted by their pairs. `right` is the right image as on the left's rows,
// before any level correction. A k below 0 (corners brighter than the centre) comes out as 0.
// Returns false, leaving `k` as it was, with fewer than 500 pairs in a channel, too narrow a
// spread of u to tell a fall-off (near scenes give a wide one), or a fit outside [-0.5, 0.75].
bool fit_lens_falloff(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                      ImageView<const float> disparity, double& k);

// The largest change of a grey level between two fall-offs' corrections (255 at the corners).
int falloff_difference(const LensFalloff& a, const LensFalloff& b);

// The correction 1 / V(r) per pixel of one image size; images through it are level-corrected as
// if the lens did not fall off (rounded; levels above 255 saturate).
class FalloffCorrection {
 public:
  // Makes the table for `falloff` at width x height x channels, unless it is the one built
  // (allocates when the size or the channels change).
  void build(const LensFalloff& falloff, int width, int height, int channels);
  bool identity() const { return identity_; }
  // Writes `image` (the built size and channels) through the table into `out`; throws
  // dco::Error for another.
  void apply(ImageView<const std::uint8_t> image, Image<std::uint8_t>& out) const;

 private:
  cv::Mat gain_;  // 1 / V per sample (float, the image's channels)
  LensFalloff falloff_;
  int width_ = 0, height_ = 0, channels_ = 0;
  bool built_ = false;
  bool identity_ = true;
};

}  // namespace dco::stereo
