#pragma once

#include <opencv2/core.hpp>

#include "dco/core/calibration.hpp"
#include "dco/core/image.hpp"

namespace dco {

// Undistortion + rectification maps for a stereo rig, built once from the calibration and applied
// per frame with cv::remap into caller-owned buffers (no allocation per frame).
// For a calibration that is already rectified the rectifier is a pass-through: `needs_remap()`
// is false and `rectify` copies.
class Rectifier {
 public:
  // Pinhole rigs are rectified with cv::stereoRectify, Kannala-Brandt rigs with
  // cv::fisheye::stereoRectify (balance 0: no invalid borders); calibrations that carry their own
  // R_rect/P_rect use those. Output size = the left camera's size, or for a pre-computed
  // rectification its rectified size (KITTI crops 1392x512 to 1242x375).
  explicit Rectifier(const StereoCalibration& calib);

  bool needs_remap() const { return needs_remap_; }
  const RectifiedGeometry& geometry() const { return geometry_; }

  // left/right: raw images of the calibrated size (1 or 3 channels, 8-bit). Outputs are resized
  // to the rectified size only if they have a different geometry (a one-time allocation).
  // Throws dco::Error when an input has the wrong size.
  void rectify(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
               Image<std::uint8_t>& left_out, Image<std::uint8_t>& right_out) const;

 private:
  bool needs_remap_ = false;
  RectifiedGeometry geometry_;
  int in_width_ = 0, in_height_ = 0;
  cv::Mat map_left_xy_, map_left_frac_, map_right_xy_, map_right_frac_;  // CV_16SC2 + CV_16UC1
};

}  // namespace dco
