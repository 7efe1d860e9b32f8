#pragma once

// Raw stereo rigs with distortion and a small relative rotation, one per camera model: what the
// rectification tests rectify (CPU, host grid and CUDA alike).

#include <opencv2/calib3d.hpp>

#include "dco/core/calibration.hpp"

namespace dco::test {

inline StereoCalibration pinhole_rig() {
  StereoCalibration c;
  c.left = {CameraModel::kPinhole, 640, 480, 500, 498, 320, 240, {-0.05, 0.01, 5e-4, -3e-4, 0}};
  c.right = {CameraModel::kPinhole, 640, 480, 505, 503, 322, 238, {-0.04, 0.008, -2e-4, 4e-4, 0}};
  cv::Mat rm;
  cv::Rodrigues(cv::Vec3d(0.01, -0.02, 0.005), rm);
  for (int i = 0; i < 9; ++i) c.rotation[i] = rm.at<double>(i / 3, i % 3);
  c.translation = {-0.1, 0.002, 0.001};
  c.source = "pinhole rig";
  return c;
}

inline StereoCalibration kannala_brandt_rig() {
  StereoCalibration c;
  c.left = {CameraModel::kKannalaBrandt, 640, 480, 280, 280, 320, 240, {0.05, -0.01, 0.002, -5e-4}};
  c.right = {CameraModel::kKannalaBrandt, 640, 480, 283, 282, 318, 242, {0.04, -0.008, 0.001, 0}};
  cv::Mat rm;
  cv::Rodrigues(cv::Vec3d(0.005, -0.01, 0.003), rm);
  for (int i = 0; i < 9; ++i) c.rotation[i] = rm.at<double>(i / 3, i % 3);
  c.translation = {-0.08, 0.001, 0.0005};
  c.source = "fisheye rig";
  return c;
}

}  // namespace dco::test
