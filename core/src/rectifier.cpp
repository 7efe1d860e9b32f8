#include "dco/core/rectifier.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include <fmt/format.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/error.hpp"

namespace dco {
namespace {

std::string origin(const StereoCalibration& c) {
  return c.source.empty() ? std::string("calibration") : c.source;
}

cv::Mat camera_matrix(const CameraIntrinsics& c) {
  return (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
}

cv::Mat distortion(const CameraIntrinsics& c) {
  // cv::fisheye insists on exactly four coefficients, even when they are all zero.
  if (c.distortion.empty())
    return c.model == CameraModel::kKannalaBrandt ? cv::Mat::zeros(4, 1, CV_64F) : cv::Mat();
  return cv::Mat(c.distortion, true);
}

cv::Mat mat3(const std::array<double, 9>& a) {
  return cv::Mat(3, 3, CV_64F, const_cast<double*>(a.data())).clone();
}

// Fixed-point maps make remap about twice as fast as float maps at the same accuracy (1/32 px).
void build_maps(const CameraIntrinsics& cam, const cv::Mat& rect_rotation, const cv::Mat& new_k,
                cv::Size size, cv::Mat& map_xy, cv::Mat& map_frac) {
  cv::Mat mx, my;
  if (cam.model == CameraModel::kKannalaBrandt)
    cv::fisheye::initUndistortRectifyMap(camera_matrix(cam), distortion(cam), rect_rotation, new_k,
                                         size, CV_32FC1, mx, my);
  else
    cv::initUndistortRectifyMap(camera_matrix(cam), distortion(cam), rect_rotation, new_k, size,
                                CV_32FC1, mx, my);
  cv::convertMaps(mx, my, map_xy, map_frac, CV_16SC2, false);
}

// Geometry from the projection matrices of a horizontal rectification.
RectifiedGeometry geometry_from(const cv::Mat& p1, const cv::Mat& p2, cv::Size size,
                                const std::string& src) {
  RectifiedGeometry g;
  g.width = size.width;
  g.height = size.height;
  g.f = p1.at<double>(0, 0);
  g.cx_left = p1.at<double>(0, 2);
  g.cx_right = p2.at<double>(0, 2);
  g.cy = p1.at<double>(1, 2);
  if (std::abs(p2.at<double>(1, 3)) > std::abs(p2.at<double>(0, 3)))
    throw Error(src + ": the cameras are stacked vertically; dco needs a side-by-side rig");
  if (!(g.f > 0) || !std::isfinite(g.f))
    throw Error(src + ": the rectification has no focal length (f = " + fmt::format("{}", g.f) +
                "): check the distortion coefficients");
  g.baseline_m = (p1.at<double>(0, 3) - p2.at<double>(0, 3)) / g.f;
  if (!(g.baseline_m > 0))
    throw Error(src + ": the right camera is not to the right of the left camera (swap them?)");
  return g;
}

// Distortion coefficients far from any lens, or a rectified focal length typed in the wrong unit,
// give a focal length orders of magnitude off the camera's, and every disparity then rounds to 0
// or overflows: say so instead.
void check_focal_length(const StereoCalibration& calib, double f, const std::string& src,
                        const char* hint) {
  const double lens_f = std::max(calib.left.fx, calib.left.fy);
  if (!(f > lens_f / 8 && f < lens_f * 8))
    throw Error(
        fmt::format("{}: the rectification is degenerate (focal length {:.4g} px from a "
                    "camera of {:.4g} px): {}",
                    src, f, lens_f, hint));
}

// The share of a fixed-point map's pixels that read inside a width x height image.
double share_inside(const cv::Mat& map_xy, int width, int height) {
  long inside = 0;
  for (int y = 0; y < map_xy.rows; ++y) {
    const cv::Vec2s* row = map_xy.ptr<cv::Vec2s>(y);
    for (int x = 0; x < map_xy.cols; ++x)
      inside += row[x][0] >= 0 && row[x][0] < width && row[x][1] >= 0 && row[x][1] < height;
  }
  return static_cast<double>(inside) / static_cast<double>(map_xy.total());
}

// Of the neighbouring rectified pixels that both sample the camera's image, the share whose
// samples run backwards (right of a pixel, left of its sample; below it, above). A distortion
// whose radial term turns back inside the view (k1 = -1 on a wide lens) folds the image: past
// the fold the rectified image shows the camera's mirrored, which the share inside does not see.
double share_folded(const cv::Mat& map_xy, int width, int height) {
  const auto inside = [&](const cv::Vec2s& p) {
    return p[0] >= 0 && p[0] < width && p[1] >= 0 && p[1] < height;
  };
  long pairs = 0, backwards = 0;
  for (int y = 0; y < map_xy.rows; ++y) {
    const cv::Vec2s* row = map_xy.ptr<cv::Vec2s>(y);
    const cv::Vec2s* below = y + 1 < map_xy.rows ? map_xy.ptr<cv::Vec2s>(y + 1) : nullptr;
    for (int x = 0; x < map_xy.cols; ++x) {
      if (!inside(row[x])) continue;
      if (x + 1 < map_xy.cols && inside(row[x + 1])) {
        ++pairs;
        backwards += row[x + 1][0] < row[x][0];
      }
      if (below && inside(below[x])) {
        ++pairs;
        backwards += below[x][1] < row[x][1];
      }
    }
  }
  return pairs > 0 ? static_cast<double>(backwards) / static_cast<double>(pairs) : 0.0;
}

void check_input(ImageView<const std::uint8_t> img, const char* side, int width, int height) {
  if (img.empty() || (img.channels != 1 && img.channels != 3))
    throw Error(fmt::format("rectify: {} image must be a non-empty 1- or 3-channel image", side));
  if (width > 0 && !img.same_size(width, height))
    throw Error(fmt::format("rectify: {} image is {}x{} but the calibration is for {}x{}", side,
                            img.width, img.height, width, height));
}

void remap_into(ImageView<const std::uint8_t> in, Image<std::uint8_t>& out, const cv::Mat& xy,
                const cv::Mat& frac) {
  cv::Mat dst = as_mat(out.view());
  const uchar* before = dst.data;
  cv::remap(as_mat(in), dst, xy, frac, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  // remap writes in place when the Mat already has the right size and type; anything else would
  // leave the caller's buffer untouched.
  if (dst.data != before) throw Error("internal: cv::remap reallocated its output");
}

}  // namespace

Rectifier::Rectifier(const StereoCalibration& calib) {
  calib.validate();
  const std::string src = origin(calib);
  if (calib.is_rectified) {
    geometry_ = calib.rectified;
    in_width_ = geometry_.width;
    in_height_ = geometry_.height;
    return;
  }
  needs_remap_ = true;
  in_width_ = calib.left.width;
  in_height_ = calib.left.height;
  const cv::Size in_size(in_width_, in_height_);
  try {
    cv::Mat r1, r2, p1, p2;
    cv::Size out_size = in_size;
    if (calib.has_rectification) {
      geometry_ = calib.rectified;
      check_focal_length(calib, geometry_.f, src, "check the rectified focal length");
      // Larger rectified images hold no more of the scene, only more memory and time.
      if (geometry_.width > 2 * in_width_ || geometry_.height > 2 * in_height_)
        throw Error(
            fmt::format("{}: rectified images of {}x{} from a camera of {}x{}: at most "
                        "twice its size a side",
                        src, geometry_.width, geometry_.height, in_width_, in_height_));
      out_size = cv::Size(geometry_.width, geometry_.height);
      r1 = mat3(calib.rect_rotation_left);
      r2 = mat3(calib.rect_rotation_right);
      // The maps only need the 3x3 part; the baseline term of P does not move pixels.
      p1 = (cv::Mat_<double>(3, 3) << geometry_.f, 0, geometry_.cx_left, 0, geometry_.f,
            geometry_.cy, 0, 0, 1);
      p2 = (cv::Mat_<double>(3, 3) << geometry_.f, 0, geometry_.cx_right, 0, geometry_.f,
            geometry_.cy, 0, 0, 1);
    } else {
      const cv::Mat rot = mat3(calib.rotation);
      const cv::Mat t(calib.translation, true);
      cv::Mat q;
      if (calib.left.model == CameraModel::kKannalaBrandt ||
          calib.right.model == CameraModel::kKannalaBrandt) {
        if (calib.left.model != calib.right.model)
          throw Error(src + ": both cameras must use the same model");
        cv::fisheye::stereoRectify(camera_matrix(calib.left), distortion(calib.left),
                                   camera_matrix(calib.right), distortion(calib.right), in_size,
                                   rot, t, r1, r2, p1, p2, q, cv::CALIB_ZERO_DISPARITY, in_size,
                                   0.0, 1.0);
      } else {
        cv::stereoRectify(camera_matrix(calib.left), distortion(calib.left),
                          camera_matrix(calib.right), distortion(calib.right), in_size, rot, t, r1,
                          r2, p1, p2, q, cv::CALIB_ZERO_DISPARITY, 0.0, in_size);
      }
      geometry_ = geometry_from(p1, p2, in_size, src);
      check_focal_length(calib, geometry_.f, src, "check the distortion coefficients");
      p1 = p1.colRange(0, 3).clone();
      p2 = p2.colRange(0, 3).clone();
    }
    build_maps(calib.left, r1, p1, out_size, map_left_xy_, map_left_frac_);
    build_maps(calib.right, r2, p2, out_size, map_right_xy_, map_right_frac_);
    // Rectified images mostly black (a wrong principal point, folded distortion) would be
    // matched as a scene: refuse them. A real rig keeps nearly all of its view.
    constexpr double kMinShareInside = 0.5;
    for (const auto& [map, side] : {std::pair{&map_left_xy_, "left"}, {&map_right_xy_, "right"}})
      if (const double share = share_inside(*map, in_width_, in_height_); share < kMinShareInside)
        throw Error(
            fmt::format("{}: only {:.1f} % of the rectified {} image falls on the "
                        "camera's (at least {:g} %): check the calibration",
                        src, 100 * share, side, 100 * kMinShareInside));
    constexpr double kMostFolded = 0.001;
    for (const auto& [map, side] : {std::pair{&map_left_xy_, "left"}, {&map_right_xy_, "right"}})
      if (const double share = share_folded(*map, in_width_, in_height_); share > kMostFolded)
        throw Error(
            fmt::format("{}: the {} camera's distortion folds its image back on itself ({:.1f} % "
                        "of the rectified neighbours sample it in reverse): check the "
                        "distortion coefficients",
                        src, side, 100 * share));
  } catch (const cv::Exception& e) {
    throw Error(src + ": cannot compute the rectification: " + e.err);
  }
}

RemapTable Rectifier::table(bool left) const {
  if (!needs_remap_) return {};
  const cv::Mat& xy = left ? map_left_xy_ : map_right_xy_;
  const cv::Mat& frac = left ? map_left_frac_ : map_right_frac_;
  return {ImageView<const std::int16_t>(xy.ptr<std::int16_t>(), xy.cols, xy.rows, 2,
                                        static_cast<int>(xy.step1())),
          ImageView<const std::uint16_t>(frac.ptr<std::uint16_t>(), frac.cols, frac.rows, 1,
                                         static_cast<int>(frac.step1()))};
}

void Rectifier::check_inputs(ImageView<const std::uint8_t> left,
                             ImageView<const std::uint8_t> right) const {
  check_input(left, "left", in_width_, in_height_);
  check_input(right, "right", in_width_, in_height_);
  if (!left.same_size(right))
    throw Error(fmt::format("rectify: left image is {}x{} but right image is {}x{}", left.width,
                            left.height, right.width, right.height));
}

void Rectifier::rectify(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                        Image<std::uint8_t>& left_out, Image<std::uint8_t>& right_out,
                        PairRemapper* remapper) const {
  check_inputs(left, right);
  if (!needs_remap_) {
    left_out.resize(left.width, left.height, left.channels);
    right_out.resize(right.width, right.height, right.channels);
    left_out.copy_from(left);
    right_out.copy_from(right);
    return;
  }
  left_out.resize(geometry_.width, geometry_.height, left.channels);
  right_out.resize(geometry_.width, geometry_.height, right.channels);
  if (remapper != nullptr) {
    remapper->remap(left, right, left_out.view(), right_out.view());
    return;
  }
  remap_into(left, left_out, map_left_xy_, map_left_frac_);
  remap_into(right, right_out, map_right_xy_, map_right_frac_);
}

}  // namespace dco
