// Public calibration API: RectifiedGeometry, StereoCalibration::validate, load_calibration (format
// detection and dispatch) and save_calibration. The parsers live in calibration_text_formats.cpp
// and calibration_toml.cpp.
#include "dco/core/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <sstream>
#include <string>
#include <string_view>

#include <fmt/format.h>

#include "calibration_internal.hpp"
#include "dco/core/error.hpp"
#include "dco/core/file_replace.hpp"
#include "dco/core/image.hpp"

namespace dco {
namespace detail {

void fail_at(const std::string& file, long line, std::string_view msg) {
  if (line > 0) throw Error(fmt::format("{}:{}: {}", file, line, msg));
  throw Error(fmt::format("{}: {}", file, msg));
}

void cameras_from_rectified(StereoCalibration& c) {
  const RectifiedGeometry& g = c.rectified;
  for (CameraIntrinsics* cam : {&c.left, &c.right}) {
    cam->model = CameraModel::kPinhole;
    cam->width = g.width;
    cam->height = g.height;
    cam->fx = cam->fy = g.f;
    cam->cx = cam == &c.left ? g.cx_left : g.cx_right;
    cam->cy = g.cy;
    cam->distortion.clear();
  }
  c.rotation = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  c.translation = {-g.baseline_m, 0, 0};
}

}  // namespace detail

namespace {

using detail::fail_at;
using detail::is_identifier;
using detail::Mat3;
using detail::mul;
using detail::split_lines;
using detail::transpose;
using detail::trim;

// ---------------------------------------------------------------------------------------------
// Validation.

double det(const Mat3& a) {
  return a[0] * (a[4] * a[8] - a[5] * a[7]) - a[1] * (a[3] * a[8] - a[5] * a[6]) +
         a[2] * (a[3] * a[7] - a[4] * a[6]);
}

// What a camera can have: a focal length below a pixel would see more than a half-space, and
// numbers far outside these ranges are typing mistakes (an exponent too many) that would
// otherwise flow through as depth a million times off, or not survive being written out.
constexpr double kMinFocalPx = 1, kMaxFocalPx = 1e6;
constexpr double kMaxPrincipalPointPx = 1e6;
constexpr double kMinBaselineM = 1e-3, kMaxBaselineM = 10;
constexpr const char* kBaselineRangeText = "1 mm..10 m (a stereo rig's; another unit?)";

bool focal_in_range(double f) {
  return f >= kMinFocalPx && f <= kMaxFocalPx;
}

bool principal_point_in_range(double c) {
  return std::abs(c) <= kMaxPrincipalPointPx;
}

std::string size_text(int w, int h) {
  return fmt::format("{}x{}", w, h);
}

void check_rotation(const std::string& src, std::string_view what, const Mat3& r) {
  // Files carry ~7 significant digits; 1e-3 accepts those and hand-typed values, rejects mistakes.
  constexpr double kTolerance = 1e-3;
  for (double v : r)
    if (!std::isfinite(v)) fail_at(src, 0, fmt::format("{} has a non-finite entry", what));
  const Mat3 rrt = mul(r, transpose(r));
  for (int i = 0; i < 9; ++i) {
    const double expected = (i % 4 == 0) ? 1.0 : 0.0;
    if (std::abs(rrt[i] - expected) > kTolerance)
      fail_at(src, 0,
              fmt::format("{} is not orthonormal (R*R^T differs from I by {:.3g})", what,
                          std::abs(rrt[i] - expected)));
  }
  if (det(r) < 0) fail_at(src, 0, fmt::format("{} is a reflection (determinant < 0)", what));
}

void check_camera(const std::string& src, std::string_view name, const CameraIntrinsics& c,
                  bool size_unknown) {
  if (!focal_in_range(c.fx) || !focal_in_range(c.fy))
    fail_at(src, 0,
            fmt::format("{} camera: focal lengths must be within {:.0f}..{:.0f} px (fx {}, fy {})",
                        name, kMinFocalPx, kMaxFocalPx, c.fx, c.fy));
  if (!principal_point_in_range(c.cx) || !principal_point_in_range(c.cy))
    fail_at(
        src, 0,
        fmt::format("{} camera: principal point ({}, {}) is more than {:.0f} px from the origin",
                    name, c.cx, c.cy, kMaxPrincipalPointPx));
  const bool size_ok =
      (c.width > 0 && c.height > 0 && c.width <= kMaxImageSide && c.height <= kMaxImageSide) ||
      (size_unknown && c.width == 0 && c.height == 0);
  if (!size_ok)
    fail_at(src, 0,
            fmt::format("{} camera: image size {} is not within 1..{} px a side", name,
                        size_text(c.width, c.height), kMaxImageSide));
  const std::size_t n = c.distortion.size();
  if (c.model == CameraModel::kPinhole && n != 0 && n != 4 && n != 5 && n != 8)
    fail_at(src, 0,
            fmt::format("{} camera: the pinhole model takes 0, 4, 5 or 8 distortion coefficients, "
                        "got {}",
                        name, n));
  if (c.model == CameraModel::kKannalaBrandt && n != 0 && n != 4)
    fail_at(src, 0,
            fmt::format("{} camera: the Kannala-Brandt model takes 0 or 4 distortion coefficients, "
                        "got {}",
                        name, n));
  for (double v : c.distortion)
    if (!std::isfinite(v))
      fail_at(src, 0, fmt::format("{} camera: a distortion coefficient is not finite", name));
}

void check_geometry(const std::string& src, const RectifiedGeometry& g, bool size_unknown) {
  if (!focal_in_range(g.f))
    fail_at(src, 0,
            fmt::format("rectified focal length must be within {:.0f}..{:.0f} px, got {}",
                        kMinFocalPx, kMaxFocalPx, g.f));
  if (!(g.baseline_m >= kMinBaselineM && g.baseline_m <= kMaxBaselineM))
    fail_at(src, 0,
            fmt::format("rectified baseline must be within {}, got {} m", kBaselineRangeText,
                        g.baseline_m));
  if (!principal_point_in_range(g.cx_left) || !principal_point_in_range(g.cx_right) ||
      !principal_point_in_range(g.cy))
    fail_at(src, 0,
            fmt::format("rectified principal point is more than {:.0f} px from the origin",
                        kMaxPrincipalPointPx));
  if (!(g.width > 0 && g.height > 0 && g.width <= kMaxImageSide && g.height <= kMaxImageSide) &&
      !size_unknown)
    fail_at(src, 0,
            fmt::format("rectified image size {} is not within 1..{} px a side",
                        size_text(g.width, g.height), kMaxImageSide));
  // Z = f * baseline / (d + doffs): a difference as wide as the image leaves no disparity in it
  // a finite depth (doffs <= -width), or every depth a sliver of the baseline (doffs >= width).
  if (!size_unknown && !(std::abs(g.doffs()) < g.width))
    fail_at(src, 0,
            fmt::format("rectified principal points differ by {} px in x (cx_right - cx_left), "
                        "not less than the image's width of {} px: every depth would be {}",
                        g.doffs(), g.width, g.doffs() < 0 ? "infinite" : "a few millimetres"));
  // The principal point is where the optical axis meets the image: a rectified one far outside
  // it (a crop offset typed twice, a sign lost) turns every ray the depth is published with, and
  // the renderers that project depth by it draw it elsewhere. Half the image's side beyond an
  // edge holds any real rectification's crop.
  if (!size_unknown) {
    const auto off = [](double c, int side) { return c < -0.5 * side || c > 1.5 * side; };
    if (off(g.cx_left, g.width) || off(g.cx_right, g.width) || off(g.cy, g.height))
      fail_at(src, 0,
              fmt::format("rectified principal point ({}, {}) / ({}, {}) lies more than half the "
                          "image's side outside the {} image",
                          g.cx_left, g.cy, g.cx_right, g.cy, size_text(g.width, g.height)));
  }
}

// ---------------------------------------------------------------------------------------------
// Reading and format detection.

std::string read_text(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    throw Error(fmt::format("{}: calibration file does not exist", path.string()));
  if (std::filesystem::is_directory(path, ec))
    throw Error(fmt::format("{}: is a directory, not a calibration file", path.string()));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot open calibration file", path.string()));
  std::ostringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  // Editors on some systems start UTF-8 files with a byte-order mark, which no format here knows.
  if (text.starts_with("\xEF\xBB\xBF")) text.erase(0, 3);
  return text;
}

enum class Format { kToml, kMiddlebury, kKeyColon };

// The first meaningful line decides "key: numbers"; Middlebury is any file with a cam0= line
// (its matrices are not valid TOML); everything else is parsed as TOML.
Format detect_format(std::string_view text) {
  bool first = true;
  for (const auto raw : split_lines(text)) {
    const auto line = trim(raw);
    if (line.empty() || line.front() == '#') continue;
    const auto colon = line.find(':');
    if (first && colon != std::string_view::npos && is_identifier(trim(line.substr(0, colon))))
      return Format::kKeyColon;
    first = false;
    const auto eq = line.find('=');
    if (eq != std::string_view::npos && trim(line.substr(0, eq)) == "cam0")
      return Format::kMiddlebury;
  }
  return Format::kToml;
}

}  // namespace

// -----------------------------------------------------------------------------------------------

double RectifiedGeometry::depth_from_disparity(double d) const {
  const double denom = d + doffs();
  // NaN and +inf too: unknown, as disparity_to_depth has it (sparse maps mark holes with +inf).
  if (!(denom > 0) || !std::isfinite(d)) return std::numeric_limits<double>::infinity();
  return f * baseline_m / denom;
}

double RectifiedGeometry::disparity_from_depth(double z_m) const {
  return f * baseline_m / z_m - doffs();
}

void StereoCalibration::validate() const {
  const std::string src = source.empty() ? std::string("calibration") : source;
  // Rectified files without a size (Karlsruhe without roi) leave it to the caller's images.
  const bool size_unknown = is_rectified && rectified.width == 0 && rectified.height == 0;
  check_camera(src, "left", left, size_unknown);
  check_camera(src, "right", right, size_unknown);
  if (left.width != right.width || left.height != right.height)
    fail_at(src, 0,
            fmt::format("left images are {} but right images are {}",
                        size_text(left.width, left.height), size_text(right.width, right.height)));
  check_rotation(src, "extrinsic rotation", rotation);
  // Two cameras that share a view look about the same way; far apart, the rectification of the
  // pair is meaningless (a camera turned round still "rectifies").
  constexpr double kMaxRigAngleDeg = 60;
  const double rig_angle_deg =
      std::acos(std::clamp((rotation[0] + rotation[4] + rotation[8] - 1) / 2, -1.0, 1.0)) * 180 /
      std::numbers::pi;
  if (rig_angle_deg > kMaxRigAngleDeg)
    fail_at(src, 0,
            fmt::format("the cameras are turned {:.1f} degrees apart (at most {:g} for a stereo "
                        "pair)",
                        rig_angle_deg, kMaxRigAngleDeg));
  for (double t : translation)
    if (!std::isfinite(t)) fail_at(src, 0, "translation is not finite");
  const double baseline = std::hypot(translation[0], translation[1], translation[2]);
  if (baseline <= 0) fail_at(src, 0, "baseline is zero (translation is 0, 0, 0)");
  if (!(baseline >= kMinBaselineM && baseline <= kMaxBaselineM))
    fail_at(src, 0,
            fmt::format("baseline {} m (the translation's length) is not within {}", baseline,
                        kBaselineRangeText));
  // A right camera far in front of or behind the left turns the rectified views away from both
  // cameras' own (the rectification's x axis is the line between them).
  constexpr double kMaxDepthOffsetDeg = 30;
  const double depth_offset_deg =
      std::asin(std::min(std::abs(translation[2]) / baseline, 1.0)) * 180 / std::numbers::pi;
  if (depth_offset_deg > kMaxDepthOffsetDeg)
    fail_at(src, 0,
            fmt::format("the right camera sits {:.1f} degrees in front of or behind the left "
                        "(translation {:g}, {:g}, {:g}; at most {:g} for a side-by-side pair)",
                        depth_offset_deg, translation[0], translation[1], translation[2],
                        kMaxDepthOffsetDeg));
  if (has_rectification) {
    check_rotation(src, "left rectifying rotation", rect_rotation_left);
    check_rotation(src, "right rectifying rotation", rect_rotation_right);
    // Rectification turns both cameras onto one frame whose x axis runs from the left camera to
    // the right: R_right R R_left^T = I, and R_right T points along -x. A file whose rectifying
    // rotations belong to other extrinsics (swapped lines, another calibration's) would leave
    // the rows apart by pixels at the edges with no word; the files' own rounding is far below.
    constexpr double kMostRectErrorDeg = 0.5;
    const Mat3 m = mul(mul(rect_rotation_right, rotation), transpose(rect_rotation_left));
    const double turn_deg =
        std::acos(std::clamp((m[0] + m[4] + m[8] - 1) / 2, -1.0, 1.0)) * 180 / std::numbers::pi;
    if (turn_deg > kMostRectErrorDeg)
      fail_at(src, 0,
              fmt::format("the rectifying rotations leave the cameras turned {:.2f} degrees apart "
                          "(at most {:g}): they do not belong to this rotation between them",
                          turn_deg, kMostRectErrorDeg));
    std::array<double, 3> axis{};
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) axis[i] += rect_rotation_right[3 * i + k] * translation[k];
    const double off_axis_deg =
        std::atan2(std::hypot(axis[1], axis[2]), -axis[0]) * 180 / std::numbers::pi;
    if (off_axis_deg > 90)
      fail_at(src, 0,
              "the rectifying rotations put the right camera left of the left one (swap them?)");
    if (off_axis_deg > kMostRectErrorDeg)
      fail_at(src, 0,
              fmt::format("the rectifying rotations put the right camera {:.2f} degrees off the "
                          "rectified x axis (at most {:g}): they do not belong to this "
                          "translation",
                          off_axis_deg, kMostRectErrorDeg));
  }
  if (is_rectified || has_rectification) {
    check_geometry(src, rectified, size_unknown);
    // Rectification turns the cameras, it does not move them: two baselines in one file that
    // disagree leave unknown which the depth should use. 5 % holds rounding and KITTI's
    // rectified baseline, 0.7 % off its translations.
    constexpr double kBaselineTolerance = 0.05;
    if (std::abs(rectified.baseline_m - baseline) > kBaselineTolerance * baseline)
      fail_at(src, 0,
              fmt::format("rectified baseline {} m differs from the translation's length {} m",
                          rectified.baseline_m, baseline));
  }
  if (is_rectified && (rectified.width != left.width || rectified.height != left.height))
    fail_at(src, 0,
            fmt::format("rectified size {} differs from the camera size {}",
                        size_text(rectified.width, rectified.height),
                        size_text(left.width, left.height)));
}

void StereoCalibration::take_size_if_unknown(int width, int height) {
  if (left.width != 0 || left.height != 0) return;
  for (int* w : {&left.width, &right.width, &rectified.width}) *w = width;
  for (int* h : {&left.height, &right.height, &rectified.height}) *h = height;
}

StereoCalibration load_calibration(const std::filesystem::path& path) {
  const std::string file = path.string();
  const std::string text = read_text(path);
  if (trim(text).empty()) fail_at(file, 0, "calibration file is empty");
  StereoCalibration c;
  switch (detect_format(text)) {
    case Format::kMiddlebury:
      c = detail::parse_middlebury(text, file);
      break;
    case Format::kKeyColon:
      c = detail::parse_key_colon(text, file);
      break;
    case Format::kToml:
      c = detail::parse_toml(text, file);
      break;
  }
  c.validate();
  return c;
}

std::string calibration_to_toml(const StereoCalibration& calib) {
  return detail::format_toml(calib);
}

StereoCalibration calibration_from_toml(std::string_view text, const std::string& source) {
  if (trim(text).empty()) fail_at(source, 0, "calibration is empty");
  StereoCalibration c = detail::parse_toml(text, source);
  c.validate();
  return c;
}

void save_calibration(const std::filesystem::path& path, const StereoCalibration& calib) {
  const std::string out = detail::format_toml(calib);
  replace_file(path, [&](const std::filesystem::path& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    if (!f) throw Error(fmt::format("{}: cannot create calibration file", path.string()));
    f << out;
    f.close();
    if (!f) throw Error(fmt::format("{}: write failed", path.string()));
  });
}

}  // namespace dco
