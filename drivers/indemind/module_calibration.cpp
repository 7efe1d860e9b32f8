#include "module_calibration.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <string_view>
#include <utility>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "dco/core/error.hpp"

namespace dco::indemind {
namespace {

// Tolerances: the blob's duplicated numbers are copies, so they agree to rounding; rotations
// follow core's validate (1e-3 accepts stored precision and rejects mistakes).
constexpr double kCopyTolerance = 1e-6;
constexpr double kRotationTolerance = 1e-3;
constexpr double kBaselineAgreement = 0.1;

// A camera of the blob under the name it gets in the result.
struct Side {
  const CameraParameter& cam;
  std::string label;  // for messages: "left camera", or with the blob's name when swapped
};

bool nearly_equal(double a, double b) {
  return std::abs(a - b) <= kCopyTolerance * std::max({1.0, std::abs(a), std::abs(b)});
}

// Scaling about pixel centres: pixel i of the full image covers [i - 0.5, i + 0.5], so a binned
// image's pixel j is centred on full-image coordinate 2j + 0.5. The vendor SDK halves c instead,
// which puts every point a quarter pixel off at 640x400.
double scale_centre(double c, double s) {
  return s == 1 ? c : (c + 0.5) * s - 0.5;  // exact at the stored size
}

[[noreturn]] void fail(const std::string& src, std::string_view msg) {
  throw Error(fmt::format("{}: {}", src, msg));
}

CameraIntrinsics intrinsics(const std::string& src, const Side& side, double s, int width,
                            int height) {
  const auto& k = side.cam.k;
  if (k[3] != 0 || k[6] != 0 || k[7] != 0 || k[8] != 1 || !(std::abs(k[1]) <= 1e-6 * k[0]))
    fail(src, fmt::format("{} K is not a camera matrix [fx 0 cx; 0 fy cy; 0 0 1]", side.label));
  const std::array<std::pair<const char*, std::pair<double, double>>, 4> copies{{
      {"fx", {side.cam.fx, k[0]}},
      {"fy", {side.cam.fy, k[4]}},
      {"cx", {side.cam.cx, k[2]}},
      {"cy", {side.cam.cy, k[5]}},
  }};
  for (const auto& [name, values] : copies)
    if (!nearly_equal(values.first, values.second))
      fail(src, fmt::format("{} {} = {} disagrees with its K entry {}", side.label, name,
                            values.first, values.second));
  CameraIntrinsics c;
  c.model = CameraModel::kKannalaBrandt;
  c.width = width;
  c.height = height;
  c.fx = k[0] * s;
  c.fy = k[4] * s;
  c.cx = scale_centre(k[2], s);
  c.cy = scale_centre(k[5], s);
  c.distortion.assign(side.cam.d.begin(), side.cam.d.end());
  return c;
}

void check_projection(const std::string& src, const Side& side) {
  const auto& p = side.cam.p;
  if (p[1] != 0 || p[4] != 0 || p[8] != 0 || p[9] != 0 || p[10] != 1 || p[11] != 0 ||
      !nearly_equal(p[0], p[5]))
    fail(src, fmt::format("{} P is not a rectified projection [f 0 cx tx; 0 f cy ty; 0 0 1 0]",
                          side.label));
  if (!(p[0] > 0))
    fail(src, fmt::format("{} P has a focal length of {}; it must be positive", side.label, p[0]));
}

RectifiedGeometry geometry(const std::string& src, const Side& left, const Side& right,
                           bool swapped, double s, int width, int height) {
  check_projection(src, left);
  check_projection(src, right);
  const auto& pl = left.cam.p;
  const auto& pr = right.cam.p;
  if (!nearly_equal(pl[0], pr[0]) || !nearly_equal(pl[6], pr[6]))
    fail(src, "the two P matrices do not describe a rectified pair (f or cy differ)");
  const double tx = pl[3] - pr[3];
  if (std::abs(pl[7] - pr[7]) > 1e-3 * std::abs(tx))
    fail(src, fmt::format("P puts the cameras {} m apart vertically; dco needs a side-by-side rig",
                          (pl[7] - pr[7]) / pl[0]));
  RectifiedGeometry g;
  g.width = width;
  g.height = height;
  g.f = pl[0] * s;
  g.cx_left = scale_centre(pl[2], s);
  g.cx_right = scale_centre(pr[2], s);
  g.cy = scale_centre(pl[6], s);
  g.baseline_m = tx / pl[0];  // independent of the scale
  if (g.baseline_m == 0) fail(src, "P gives a zero baseline (P_left[3] == P_right[3])");
  if (!(g.baseline_m > 0))
    fail(src, fmt::format("the right camera is on the wrong side: P gives a baseline of {} m ({})",
                          g.baseline_m,
                          swapped ? "the module type swaps the sensor halves; does this blob "
                                    "already name the cameras as delivered?"
                                  : "are the sensor halves swapped on this module?"));
  return g;
}

cv::Matx44d rigid_transform(const std::string& src, const Side& side) {
  const cv::Matx44d t(side.cam.t_sc.data());
  if (t(3, 0) != 0 || t(3, 1) != 0 || t(3, 2) != 0 || t(3, 3) != 1)
    fail(src, fmt::format("{} T_SC's last row is not 0 0 0 1", side.label));
  const cv::Matx33d r = t.get_minor<3, 3>(0, 0);
  const cv::Matx33d rrt = r * r.t();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (std::abs(rrt(i, j) - (i == j ? 1.0 : 0.0)) > kRotationTolerance)
        fail(src, fmt::format("{} T_SC's rotation is not orthonormal", side.label));
  if (cv::determinant(r) < 0)
    fail(src, fmt::format("{} T_SC's rotation is a reflection", side.label));
  return t;
}

cv::Matx44d inverse_rigid(const cv::Matx44d& t) {
  const cv::Matx33d rt = t.get_minor<3, 3>(0, 0).t();
  const cv::Vec3d p = -(rt * cv::Vec3d(t(0, 3), t(1, 3), t(2, 3)));
  return {rt(0, 0), rt(0, 1), rt(0, 2), p[0], rt(1, 0), rt(1, 1), rt(1, 2), p[1],
          rt(2, 0), rt(2, 1), rt(2, 2), p[2], 0,        0,        0,        1};
}

// Right-in-left pose from the two camera -> IMU transforms.
void extrinsics(const std::string& src, const Side& left, const Side& right, StereoCalibration& c) {
  const cv::Matx44d rl = inverse_rigid(rigid_transform(src, right)) * rigid_transform(src, left);
  for (int i = 0; i < 9; ++i) c.rotation[i] = rl(i / 3, i % 3);
  c.translation = {rl(0, 3), rl(1, 3), rl(2, 3)};
  // The right camera's centre in the left frame: -R^T T.
  const cv::Matx33d r = rl.get_minor<3, 3>(0, 0);
  const cv::Vec3d centre = -(r.t() * cv::Vec3d(rl(0, 3), rl(1, 3), rl(2, 3)));
  const double length = cv::norm(centre);
  const double b = c.rectified.baseline_m;
  if (!(centre[0] > 0))
    fail(src, fmt::format("the camera-to-IMU transforms put the right camera at x = {} m in the "
                          "left camera's frame; it must be at +x",
                          centre[0]));
  if (std::abs(length - b) > kBaselineAgreement * b)
    fail(src, fmt::format("the camera-to-IMU transforms give a baseline of {} m but P gives {} m",
                          length, b));
}

std::string clean(const std::string& s) {
  std::string out = s.substr(0, 32);
  for (char& ch : out)
    if (static_cast<unsigned char>(ch) < 0x20 || static_cast<unsigned char>(ch) > 0x7e) ch = '?';
  return out;
}

}  // namespace

StereoCalibration to_stereo_calibration(const ModuleCalibration& m, int width, int height) {
  const std::string id = clean(m.info.id);
  const std::string src =
      id.empty() ? std::string("INDEMIND calibration") : "INDEMIND calibration of module " + id;
  const bool swap = swaps_halves(m.module_type);
  const char* type = m.module_type == ModuleType::kAr ? "AR" : "MR";
  const Side left{swap ? m.right : m.left,
                  swap ? fmt::format("left camera (the blob's right: {} module)", type)
                       : std::string("left camera")};
  const Side right{swap ? m.left : m.right,
                   swap ? fmt::format("right camera (the blob's left: {} module)", type)
                        : std::string("right camera")};

  const int stored_w = left.cam.width, stored_h = left.cam.height;
  if (right.cam.width != stored_w || right.cam.height != stored_h)
    fail(src, fmt::format("the cameras are calibrated for different sizes ({}x{} and {}x{})",
                          stored_w, stored_h, right.cam.width, right.cam.height));
  double s = 0;
  if (width == stored_w && height == stored_h)
    s = 1;
  else if (2LL * width == stored_w && 2LL * height == stored_h)
    s = 0.5;
  else
    fail(src, fmt::format("no calibration for {}x{}: the module is calibrated for {}x{} (and "
                          "supports exactly half of that)",
                          width, height, stored_w, stored_h));

  StereoCalibration c;
  c.source = src;
  c.left = intrinsics(src, left, s, width, height);
  c.right = intrinsics(src, right, s, width, height);
  c.has_rectification = true;
  c.is_rectified = false;
  std::copy(left.cam.r.begin(), left.cam.r.end(), c.rect_rotation_left.begin());
  std::copy(right.cam.r.begin(), right.cam.r.end(), c.rect_rotation_right.begin());
  c.rectified = geometry(src, left, right, swap, s, width, height);
  extrinsics(src, left, right, c);
  c.validate();
  return c;
}

std::string describe(const ModuleInfo& info) {
  std::string out = "INDEMIND module";
  const std::string id = clean(info.id);
  if (!id.empty()) out += " " + id;
  std::string details;
  for (const auto& [label, value] : {std::pair{"firmware ", clean(info.firmware_version)},
                                     std::pair{"hardware ", clean(info.hardware_version)}}) {
    if (value.empty()) continue;
    if (!details.empty()) details += ", ";
    details += label + value;
  }
  if (!details.empty()) out += " (" + details + ")";
  return out;
}

}  // namespace dco::indemind
