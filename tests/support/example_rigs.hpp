#pragma once

// Raw stereo rigs with distortion and a small relative rotation, one per camera model: what the
// rectification tests rectify (CPU, host grid and CUDA alike).

#include <array>

#include <opencv2/calib3d.hpp>

#include "dco/core/calibration.hpp"

namespace dco::test {

// The two cameras, the right camera's rotation (Rodrigues vector) and translation.
inline StereoCalibration rig(const CameraIntrinsics& left, const CameraIntrinsics& right,
                             const cv::Vec3d& rotation, std::array<double, 3> translation,
                             const char* source) {
  StereoCalibration c;
  c.left = left;
  c.right = right;
  cv::Mat rm;
  cv::Rodrigues(rotation, rm);
  for (int i = 0; i < 9; ++i) c.rotation[i] = rm.at<double>(i / 3, i % 3);
  c.translation = translation;
  c.source = source;
  return c;
}

inline StereoCalibration pinhole_rig() {
  return rig({CameraModel::kPinhole, 640, 480, 500, 498, 320, 240, {-0.05, 0.01, 5e-4, -3e-4, 0}},
             {CameraModel::kPinhole, 640, 480, 505, 503, 322, 238, {-0.04, 0.008, -2e-4, 4e-4, 0}},
             {0.01, -0.02, 0.005}, {-0.1, 0.002, 0.001}, "pinhole rig");
}

inline StereoCalibration kannala_brandt_rig() {
  return rig(
      {CameraModel::kKannalaBrandt, 640, 480, 280, 280, 320, 240, {0.05, -0.01, 0.002, -5e-4}},
      {CameraModel::kKannalaBrandt, 640, 480, 283, 282, 318, 242, {0.04, -0.008, 0.001, 0}},
      {0.005, -0.01, 0.003}, {-0.08, 0.001, 0.0005}, "fisheye rig");
}

}  // namespace dco::test
