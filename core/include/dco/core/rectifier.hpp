#pragma once

#include <opencv2/core.hpp>

#include "dco/core/calibration.hpp"
#include "dco/core/image.hpp"

namespace dco {

// One camera's fixed-point rectification map, as cv::convertMaps makes it (CV_16SC2 + CV_16UC1):
// output pixel (x, y) interpolates the raw image bilinearly around the integer source position
// xy(x, y) = (sx, sy) with the 1/32-pixel fraction frac(x, y) = fy * 32 + fx.
struct RemapTable {
  ImageView<const std::int16_t> xy;  // two channels: sx, sy
  ImageView<const std::uint16_t> frac;
};

// Applies a rig's two remap tables to a raw pair, somewhere other than cv::remap (the CUDA
// backend's is dco::gpu::make_cuda_pair_remapper). It must give cv::remap's bytes (INTER_LINEAR,
// constant 0 border). Outputs come sized to the rectified geometry with the inputs' channels.
class PairRemapper {
 public:
  virtual ~PairRemapper() = default;
  virtual void remap(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                     ImageView<std::uint8_t> left_out, ImageView<std::uint8_t> right_out) = 0;
};

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
  // Throws dco::Error when an input has the wrong size. With a remapper the maps are applied by
  // it instead of cv::remap (same bytes).
  void rectify(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
               Image<std::uint8_t>& left_out, Image<std::uint8_t>& right_out,
               PairRemapper* remapper = nullptr) const;

  // Throws dco::Error unless left and right are images rectify() takes: 1 or 3 channels, one
  // size, the calibrated one where the calibration gives it (a pass-through included).
  void check_inputs(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right) const;

  // The raw image size the maps read (0 x 0 for a pass-through of unknown size).
  int input_width() const { return in_width_; }
  int input_height() const { return in_height_; }
  // The maps of the left (true) or right camera; empty views for a pass-through.
  RemapTable table(bool left) const;

 private:
  bool needs_remap_ = false;
  RectifiedGeometry geometry_;
  int in_width_ = 0, in_height_ = 0;
  cv::Mat map_left_xy_, map_left_frac_, map_right_xy_, map_right_frac_;  // CV_16SC2 + CV_16UC1
};

}  // namespace dco
