#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace dco {

enum class CameraModel {
  kPinhole,        // OpenCV radial-tangential distortion: k1 k2 p1 p2 [k3 [k4 k5 k6]]
  kKannalaBrandt,  // equidistant fisheye (OpenCV cv::fisheye): k1 k2 k3 k4
};

struct CameraIntrinsics {
  CameraModel model = CameraModel::kPinhole;
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::vector<double> distortion;  // empty = none
};

// Geometry of a rectified pair: both images share f and cy, rows are epipolar lines, and a point
// at left column x appears in the right image at x - d.
struct RectifiedGeometry {
  int width = 0;
  int height = 0;
  double f = 0;           // pixels
  double cx_left = 0;     // pixels
  double cx_right = 0;    // pixels; differs from cx_left only for datasets like Middlebury
  double cy = 0;          // pixels
  double baseline_m = 0;  // metres, > 0

  // Middlebury's doffs: the x-difference of the principal points.
  double doffs() const { return cx_right - cx_left; }
  // Metric depth (metres) of a disparity in pixels of this geometry; +inf (unknown) when
  // d + doffs <= 0 or d is not finite.
  double depth_from_disparity(double d) const;
  // Inverse of depth_from_disparity: f * baseline / z - doffs.
  double disparity_from_depth(double z_m) const;
};

// A calibrated stereo rig. When `is_rectified` is true the images are already rectified (dataset
// files, cameras that rectify on board) and `rectified` describes them; otherwise the rectifier
// computes `rectified` from the raw intrinsics and extrinsics.
struct StereoCalibration {
  CameraIntrinsics left;
  CameraIntrinsics right;
  // Pose of the right camera in the left camera's frame: x_right = R * x_left + T (metres).
  std::array<double, 9> rotation{1, 0, 0, 0, 1, 0, 0, 0, 1};  // row-major
  std::array<double, 3> translation{0, 0, 0};
  // Pre-computed rectification (KITTI/Karlsruhe style files carry R_rect and P_rect): when present
  // the rectifier uses them instead of computing its own.
  bool has_rectification = false;
  std::array<double, 9> rect_rotation_left{1, 0, 0, 0, 1, 0, 0, 0, 1};
  std::array<double, 9> rect_rotation_right{1, 0, 0, 0, 1, 0, 0, 0, 1};

  bool is_rectified = false;
  RectifiedGeometry rectified;

  std::string source;  // file it came from, for messages

  // Throws dco::Error naming the first inconsistency (non-positive focal length, wrong number of
  // distortion coefficients, zero baseline, non-orthonormal rotation, ...).
  void validate() const;

  // A rectified calibration that gives no image size (Karlsruhe without roi) takes the images':
  // both cameras and the rectified geometry get width x height. Any other one is left alone.
  void take_size_if_unknown(int width, int height);
};

// Loads any calibration format dco understands, chosen by content:
//  - dco's own TOML format (docs/calibration.md), files ending in .toml;
//  - Middlebury calib.txt (cam0=[...] cam1=[...] doffs= baseline= width= height=), baseline in mm;
//  - KITTI / Karlsruhe "key: numbers" files (K_02/D_02/R_rect_02/P_rect_02 and K_03..., or
//    K1/D1/R1/P1 and K2..., with optional P1_roi/P2_roi for images already rectified and cropped).
// Throws dco::Error with the file (and line where known) on any problem.
StereoCalibration load_calibration(const std::filesystem::path& path);

// Writes dco's own TOML format; load_calibration reads it back to the same values.
void save_calibration(const std::filesystem::path& path, const StereoCalibration& calib);

// The same TOML as text, and back (validated; errors name `source` and the line), for
// calibrations that travel inside recordings.
std::string calibration_to_toml(const StereoCalibration& calib);
StereoCalibration calibration_from_toml(std::string_view text, const std::string& source);

}  // namespace dco
