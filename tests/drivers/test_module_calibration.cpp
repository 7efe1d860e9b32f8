#include "../../drivers/indemind/module_calibration.hpp"

#include <cmath>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "dco/core/error.hpp"
#include "dco/core/image.hpp"
#include "dco/core/rectifier.hpp"
#include "support/error_of.hpp"

namespace dco::indemind {
namespace {

// A physical rig, the ground truth the blobs are made from: two KB4 cameras for 1280x800
// (2.09 mm lens over 3 um pixels: f ~ 697 px), the right one 0.12 m along the left one's x with a
// small relative rotation, rectified by OpenCV like the factory tool does.
struct Rig {
  cv::Matx33d k_left, k_right;
  cv::Vec4d d_left, d_right;
  cv::Matx33d rotation;    // x_right = rotation * x_left + translation
  cv::Vec3d translation;   // metres
  cv::Vec3d right_centre;  // the right camera's centre in the left frame
  cv::Matx33d r_left, r_right;
  cv::Matx34d p_left, p_right;
  cv::Matx44d t_sc_left, t_sc_right;  // camera -> IMU
};

const cv::Size kStoredSize(1280, 800);

Rig make_rig() {
  Rig g;
  g.k_left = {697.2, 0, 641.3, 0, 696.8, 398.7, 0, 0, 1};
  g.k_right = {699.1, 0, 636.9, 0, 698.5, 403.2, 0, 0, 1};
  g.d_left = {-0.0123, 0.0041, -0.00162, 0.00021};
  g.d_right = {-0.0101, 0.0035, -0.00121, 0.00015};
  cv::Rodrigues(cv::Vec3d(0.004, -0.006, 0.002), g.rotation);
  g.right_centre = {0.12, 0.0008, -0.0005};
  g.translation = -(g.rotation * g.right_centre);
  cv::Mat r1, r2, p1, p2, q;
  cv::fisheye::stereoRectify(g.k_left, g.d_left, g.k_right, g.d_right, kStoredSize, g.rotation,
                             g.translation, r1, r2, p1, p2, q, cv::CALIB_ZERO_DISPARITY,
                             kStoredSize, 0.0, 1.0);
  g.r_left = r1;
  g.r_right = r2;
  g.p_left = p1;
  g.p_right = p2;
  // The IMU 60 mm beside the left camera, its axes turned 180 degrees about z.
  g.t_sc_left = {-1, 0, 0, 0.06, 0, -1, 0, 0.002, 0, 0, 1, -0.001, 0, 0, 0, 1};
  cv::Matx44d right_from_left = cv::Matx44d::eye();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) right_from_left(i, j) = g.rotation(i, j);
    right_from_left(i, 3) = g.translation[i];
  }
  g.t_sc_right = g.t_sc_left * right_from_left.inv();
  return g;
}

template <typename M>
void copy_to(const M& from, double* to) {
  for (int i = 0; i < M::rows * M::cols; ++i) to[i] = from.val[i];
}

CameraParameter camera_parameter(const cv::Matx33d& k, const cv::Vec4d& d, const cv::Matx33d& r,
                                 const cv::Matx34d& p, const cv::Matx44d& t_sc) {
  CameraParameter c;
  copy_to(t_sc, c.t_sc.data());
  c.width = kStoredSize.width;
  c.height = kStoredSize.height;
  c.fx = k(0, 0);
  c.fy = k(1, 1);
  c.cx = k(0, 2);
  c.cy = k(1, 2);
  copy_to(r, c.r.data());
  copy_to(p, c.p.data());
  copy_to(k, c.k.data());
  for (int i = 0; i < 4; ++i) c.d[i] = d[i];
  return c;
}

// The blob of `rig`. Cameras are stored by sensor half, and on AR/MR modules the first half shows
// the physically right camera.
ModuleCalibration module_of(const Rig& rig, ModuleType type = ModuleType::kNormal) {
  ModuleCalibration m;
  m.version = 2;
  m.left = camera_parameter(rig.k_left, rig.d_left, rig.r_left, rig.p_left, rig.t_sc_left);
  m.right = camera_parameter(rig.k_right, rig.d_right, rig.r_right, rig.p_right, rig.t_sc_right);
  if (swaps_halves(type)) std::swap(m.left, m.right);
  m.imu.g = 9.8019967;
  m.imu.sigma_g_c = 0.0021;
  m.imu.sigma_a_c = 0.088;
  m.imu.t_bs = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  m.info = {"M1", "INDEMIND", "1.0", "H2", "2.1mm", "ICM-20602", "130", "120mm"};
  m.img_frequency = 50;
  m.img_resolution = 1280;
  m.imu_frequency = 1000;
  m.module_type = type;
  return m;
}

using dco::testing::error_of;

// ---------------------------------------------------------------------------------------------
// Photographing dots: a point is projected by the rig's own KB4 cameras, drawn as a Gaussian dot
// in each raw image, and the rectified images are searched for it.

cv::Point2d project(const cv::Matx33d& k, const cv::Vec4d& d, const cv::Point3d& p,
                    const cv::Matx33d& rotation, const cv::Vec3d& translation) {
  cv::Vec3d rvec;
  cv::Rodrigues(rotation, rvec);
  std::vector<cv::Point2d> out;
  cv::fisheye::projectPoints(std::vector<cv::Point3d>{p}, out, rvec, translation, k, d);
  return out[0];
}

void draw_dot(Image<std::uint8_t>& img, cv::Point2d at) {
  img.fill(0);
  constexpr double kSigma = 2.0;
  for (int y = static_cast<int>(at.y) - 9; y <= static_cast<int>(at.y) + 10; ++y)
    for (int x = static_cast<int>(at.x) - 9; x <= static_cast<int>(at.x) + 10; ++x) {
      if (x < 0 || y < 0 || x >= img.width() || y >= img.height()) continue;
      const double r2 = (x - at.x) * (x - at.x) + (y - at.y) * (y - at.y);
      img.at(x, y) = static_cast<std::uint8_t>(250.0 * std::exp(-r2 / (2 * kSigma * kSigma)) + 0.5);
    }
}

// Intensity-weighted centroid around the brightest pixel; nothing when the dot left the image.
std::optional<cv::Point2d> find_dot(const Image<std::uint8_t>& img) {
  int bx = 0, by = 0, best = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      if (img.at(x, y) > best) {
        best = img.at(x, y);
        bx = x;
        by = y;
      }
  constexpr int kWindow = 9;
  if (best < 200 || bx < kWindow || by < kWindow || bx >= img.width() - kWindow ||
      by >= img.height() - kWindow)
    return std::nullopt;
  double sw = 0, sx = 0, sy = 0;
  for (int y = by - kWindow; y <= by + kWindow; ++y)
    for (int x = bx - kWindow; x <= bx + kWindow; ++x) {
      const double w = img.at(x, y);
      sw += w;
      sx += w * x;
      sy += w * y;
    }
  return cv::Point2d(sx / sw, sy / sw);
}

struct Measurement {
  int measured = 0;
  double max_dy = 0;               // row difference between the two rectified dots
  double max_disparity_error = 0;  // against f * B / Z
  double max_position_error = 0;   // left dot against the geometry's own projection
};

// Rectifies dots of `points` (left camera frame) photographed at width x height, which is the
// stored size or half of it (a 2x2-binned image: pixel centres map by (u + 0.5) * s - 0.5).
Measurement measure(const Rig& rig, const StereoCalibration& calib,
                    const std::vector<cv::Point3d>& points) {
  const Rectifier rect(calib);
  const RectifiedGeometry& g = rect.geometry();
  const double s = static_cast<double>(calib.left.width) / kStoredSize.width;
  const auto to_image = [s](cv::Point2d p) {
    return cv::Point2d((p.x + 0.5) * s - 0.5, (p.y + 0.5) * s - 0.5);
  };
  const double baseline = cv::norm(rig.right_centre);
  Image<std::uint8_t> raw_l(calib.left.width, calib.left.height);
  Image<std::uint8_t> raw_r(calib.left.width, calib.left.height);
  Image<std::uint8_t> out_l, out_r;
  Measurement res;
  for (const cv::Point3d& p : points) {
    draw_dot(raw_l, to_image(project(rig.k_left, rig.d_left, p, cv::Matx33d::eye(), cv::Vec3d())));
    draw_dot(raw_r, to_image(project(rig.k_right, rig.d_right, p, rig.rotation, rig.translation)));
    rect.rectify(raw_l.cview(), raw_r.cview(), out_l, out_r);
    const auto l = find_dot(out_l), r = find_dot(out_r);
    if (!l || !r) continue;
    ++res.measured;
    // Depth along the rectified optical axis: rectification only turns the left camera.
    const cv::Vec3d q = rig.r_left * cv::Vec3d(p.x, p.y, p.z);
    const cv::Point2d expected(g.f * q[0] / q[2] + g.cx_left, g.f * q[1] / q[2] + g.cy);
    res.max_dy = std::max(res.max_dy, std::abs(l->y - r->y));
    res.max_disparity_error =
        std::max(res.max_disparity_error, std::abs(l->x - r->x - g.f * baseline / q[2]));
    res.max_position_error = std::max(res.max_position_error, cv::norm(*l - expected));
  }
  return res;
}

std::vector<cv::Point3d> grid() {
  std::vector<cv::Point3d> pts;
  for (double z : {0.8, 2.5})
    for (double y : {-0.35, 0.0, 0.3})
      for (double x : {-0.6, -0.25, 0.05, 0.4, 0.7}) pts.emplace_back(x * z, y * z, z);
  return pts;
}

// ---------------------------------------------------------------------------------------------

TEST(ModuleCalibration, ConvertsAtTheStoredSize) {
  const Rig rig = make_rig();
  ASSERT_LT(rig.p_right(0, 3), 0);  // the factory convention this conversion expects
  const StereoCalibration c = to_stereo_calibration(module_of(rig), 1280, 800);
  EXPECT_EQ(c.left.model, CameraModel::kKannalaBrandt);
  EXPECT_EQ(c.right.model, CameraModel::kKannalaBrandt);
  EXPECT_EQ(c.left.width, 1280);
  EXPECT_EQ(c.right.height, 800);
  EXPECT_EQ(c.left.fx, 697.2);
  EXPECT_EQ(c.left.fy, 696.8);
  EXPECT_EQ(c.right.cx, 636.9);
  EXPECT_EQ(c.right.cy, 403.2);
  EXPECT_EQ(c.left.distortion, (std::vector<double>{-0.0123, 0.0041, -0.00162, 0.00021}));
  EXPECT_EQ(c.right.distortion, (std::vector<double>{-0.0101, 0.0035, -0.00121, 0.00015}));
  EXPECT_TRUE(c.has_rectification);
  EXPECT_FALSE(c.is_rectified);
  for (int i = 0; i < 9; ++i) {
    EXPECT_EQ(c.rect_rotation_left[i], rig.r_left.val[i]);
    EXPECT_EQ(c.rect_rotation_right[i], rig.r_right.val[i]);
    EXPECT_NEAR(c.rotation[i], rig.rotation.val[i], 1e-12);
  }
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(c.translation[i], rig.translation[i], 1e-12);
  const RectifiedGeometry& g = c.rectified;
  EXPECT_EQ(g.width, 1280);
  EXPECT_EQ(g.height, 800);
  EXPECT_EQ(g.f, rig.p_left(0, 0));
  EXPECT_EQ(g.cx_left, rig.p_left(0, 2));
  EXPECT_EQ(g.cx_right, rig.p_right(0, 2));
  EXPECT_EQ(g.cy, rig.p_left(1, 2));
  EXPECT_NEAR(g.baseline_m, 0.12, 0.0001);
  EXPECT_NEAR(g.baseline_m, cv::norm(rig.right_centre), 1e-9);
  EXPECT_NE(c.source.find("M1"), std::string::npos);
}

TEST(ModuleCalibration, RectifiedRowsAndDisparityMatchTheRig) {
  const Rig rig = make_rig();
  const auto pts = grid();
  const Measurement m = measure(rig, to_stereo_calibration(module_of(rig), 1280, 800), pts);
  EXPECT_GE(m.measured, static_cast<int>(pts.size()) * 8 / 10);
  EXPECT_LT(m.max_dy, 0.1);
  EXPECT_LT(m.max_disparity_error, 0.1);
  EXPECT_LT(m.max_position_error, 0.1);
}

TEST(ModuleCalibration, HalfSizeScalesAboutPixelCentres) {
  const Rig rig = make_rig();
  const ModuleCalibration blob = module_of(rig);
  const StereoCalibration full = to_stereo_calibration(blob, 1280, 800);
  const StereoCalibration half = to_stereo_calibration(blob, 640, 400);
  const auto centre = [](double c) { return (c + 0.5) / 2 - 0.5; };
  const RectifiedGeometry &f = full.rectified, &h = half.rectified;
  EXPECT_EQ(h.width, 640);
  EXPECT_EQ(h.height, 400);
  EXPECT_DOUBLE_EQ(h.f, f.f / 2);
  EXPECT_DOUBLE_EQ(h.cx_left, centre(f.cx_left));
  EXPECT_DOUBLE_EQ(h.cx_right, centre(f.cx_right));
  EXPECT_DOUBLE_EQ(h.cy, centre(f.cy));
  EXPECT_DOUBLE_EQ(h.baseline_m, f.baseline_m);
  for (const auto& [hc, fc] : {std::pair{&half.left, &full.left}, {&half.right, &full.right}}) {
    EXPECT_EQ(hc->width, 640);
    EXPECT_DOUBLE_EQ(hc->fx, fc->fx / 2);
    EXPECT_DOUBLE_EQ(hc->fy, fc->fy / 2);
    EXPECT_DOUBLE_EQ(hc->cx, centre(fc->cx));
    EXPECT_DOUBLE_EQ(hc->cy, centre(fc->cy));
    EXPECT_EQ(hc->distortion, fc->distortion);  // KB4 acts on angles: no scaling
  }
  EXPECT_EQ(half.rotation, full.rotation);
  EXPECT_EQ(half.translation, full.translation);
  EXPECT_EQ(half.rect_rotation_left, full.rect_rotation_left);

  // Binned images of the rig rectify onto the half-size geometry; the vendor's plain halving of
  // cx, cy would put every dot a quarter pixel off.
  const auto pts = grid();
  const Measurement m = measure(rig, half, pts);
  EXPECT_GE(m.measured, static_cast<int>(pts.size()) * 8 / 10);
  EXPECT_LT(m.max_dy, 0.1);
  EXPECT_LT(m.max_disparity_error, 0.1);
  EXPECT_LT(m.max_position_error, 0.1);
}

TEST(ModuleCalibration, OnlyTheStoredSizeAndHalfOfIt) {
  const ModuleCalibration blob = module_of(make_rig());
  const std::string msg = error_of([&] { to_stereo_calibration(blob, 960, 600); });  // 0.75
  EXPECT_NE(msg.find("960x600"), std::string::npos) << msg;
  EXPECT_NE(msg.find("1280x800"), std::string::npos) << msg;
  for (const auto& [w, h] :
       {std::pair{640, 800}, {1280, 400}, {320, 200}, {2560, 1600}, {641, 400}, {0, 0}})
    EXPECT_THROW(to_stereo_calibration(blob, w, h), Error) << w << "x" << h;
}

TEST(ModuleCalibration, ArAndMrModulesPutTheSmallerXCameraOnTheLeft) {
  const Rig rig = make_rig();
  const StereoCalibration normal = to_stereo_calibration(module_of(rig), 1280, 800);
  for (ModuleType type : {ModuleType::kAr, ModuleType::kMr}) {
    SCOPED_TRACE(static_cast<int>(type));
    const ModuleCalibration blob = module_of(rig, type);
    ASSERT_EQ(blob.left.fx, rig.k_right(0, 0));  // the first sensor half is the right camera
    for (int size : {1, 2}) {
      const StereoCalibration c = to_stereo_calibration(blob, 1280 / size, 800 / size);
      const StereoCalibration n =
          size == 1 ? normal : to_stereo_calibration(module_of(rig), 640, 400);
      EXPECT_EQ(c.left.fx, n.left.fx);
      EXPECT_EQ(c.left.cx, n.left.cx);
      EXPECT_EQ(c.left.distortion, n.left.distortion);
      EXPECT_EQ(c.right.fx, n.right.fx);
      EXPECT_EQ(c.rect_rotation_left, n.rect_rotation_left);
      EXPECT_EQ(c.rect_rotation_right, n.rect_rotation_right);
      EXPECT_EQ(c.rectified.cx_left, n.rectified.cx_left);
      EXPECT_EQ(c.rectified.baseline_m, n.rectified.baseline_m);
      EXPECT_EQ(c.rotation, n.rotation);
      EXPECT_EQ(c.translation, n.translation);
    }
    // The right camera sits at +x in the left camera's frame: centre = -R^T T.
    const StereoCalibration c = to_stereo_calibration(blob, 1280, 800);
    const cv::Matx33d r(c.rotation.data());
    const cv::Vec3d centre = -(r.t() * cv::Vec3d(c.translation.data()));
    EXPECT_NEAR(centre[0], 0.12, 1e-9);

    // The same halves read as a normal module: the cameras are the wrong way round.
    ModuleCalibration as_normal = blob;
    as_normal.module_type = ModuleType::kNormal;
    EXPECT_NE(error_of([&] { to_stereo_calibration(as_normal, 1280, 800); }).find("wrong side"),
              std::string::npos);
  }
  // And a normal blob claiming to be AR.
  ModuleCalibration wrong = module_of(rig);
  wrong.module_type = ModuleType::kAr;
  EXPECT_NE(error_of([&] { to_stereo_calibration(wrong, 1280, 800); }).find("wrong side"),
            std::string::npos);
}

TEST(ModuleCalibration, KMustAgreeWithFxFyCxCy) {
  const ModuleCalibration good = module_of(make_rig());
  for (int field = 0; field < 4; ++field) {
    ModuleCalibration m = good;
    double* v[] = {&m.right.fx, &m.right.fy, &m.right.cx, &m.right.cy};
    *v[field] *= 1 + 1e-8;  // rounding: fine
    EXPECT_NO_THROW(to_stereo_calibration(m, 1280, 800));
    *v[field] *= 1 + 1e-4;
    const std::string msg = error_of([&] { to_stereo_calibration(m, 1280, 800); });
    const char* names[] = {"fx", "fy", "cx", "cy"};
    EXPECT_NE(msg.find(std::string("right camera ") + names[field] + " ="), std::string::npos)
        << msg;
  }
  ModuleCalibration skewed = good;
  skewed.left.k[1] = 0.5;
  EXPECT_NE(error_of([&] { to_stereo_calibration(skewed, 1280, 800); }).find("left camera K"),
            std::string::npos);
}

TEST(ModuleCalibration, RejectsInconsistentGeometry) {
  const Rig rig = make_rig();
  const ModuleCalibration good = module_of(rig);
  struct Case {
    const char* name;
    void (*edit)(ModuleCalibration&);
    const char* message;
  };
  const Case cases[] = {
      {"non-orthonormal R", [](ModuleCalibration& m) { m.right.r[0] *= 1.01; },
       "right rectifying rotation is not orthonormal"},
      {"reflecting R",
       [](ModuleCalibration& m) {
         for (int i = 6; i < 9; ++i) m.left.r[i] = -m.left.r[i];
       },
       "reflection"},
      {"zero baseline", [](ModuleCalibration& m) { m.right.p[3] = m.left.p[3]; }, "zero baseline"},
      {"right camera on the left", [](ModuleCalibration& m) { m.right.p[3] = -m.right.p[3]; },
       "wrong side"},
      {"different rectified f", [](ModuleCalibration& m) { m.right.p[0] = m.right.p[5] += 1; },
       "rectified pair"},
      {"different rectified cy", [](ModuleCalibration& m) { m.right.p[6] += 1; }, "rectified pair"},
      {"vertical offset", [](ModuleCalibration& m) { m.right.p[7] = m.right.p[3]; }, "vertically"},
      {"P not a projection", [](ModuleCalibration& m) { m.left.p[10] = 2; }, "left camera P"},
      {"T_SC not rigid", [](ModuleCalibration& m) { m.left.t_sc[0] = -1.1; },
       "left camera T_SC's rotation is not orthonormal"},
      {"T_SC last row", [](ModuleCalibration& m) { m.right.t_sc[12] = 0.1; },
       "right camera T_SC's last row"},
      {"T_SC baseline in mm",
       [](ModuleCalibration& m) {
         for (auto* c : {&m.left, &m.right})
           for (int i : {3, 7, 11}) c->t_sc[i] *= 1000;
       },
       "baseline of"},
      {"T_SC cameras swapped", [](ModuleCalibration& m) { std::swap(m.left.t_sc, m.right.t_sc); },
       "must be at +x"},
      {"different sizes", [](ModuleCalibration& m) { m.right.width = 640; }, "different sizes"},
      {"NaN built by hand", [](ModuleCalibration& m) { m.left.d[2] = std::nan(""); },
       "distortion coefficient is not finite"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    ModuleCalibration m = good;
    c.edit(m);
    const std::string msg = error_of([&] { to_stereo_calibration(m, 1280, 800); });
    EXPECT_NE(msg.find(c.message), std::string::npos) << msg;
    EXPECT_NE(msg.find("INDEMIND"), std::string::npos) << msg;
  }
}

TEST(ModuleCalibration, ParsedBlobConvertsLikeTheOriginal) {
  const Rig rig = make_rig();
  const ModuleCalibration m = module_of(rig, ModuleType::kMr);
  const ModuleCalibration back = parse_calibration_blob(encode_calibration_blob(m));
  const StereoCalibration a = to_stereo_calibration(m, 640, 400);
  const StereoCalibration b = to_stereo_calibration(back, 640, 400);
  EXPECT_EQ(a.left.cx, b.left.cx);
  EXPECT_EQ(a.rectified.baseline_m, b.rectified.baseline_m);
  EXPECT_EQ(a.translation, b.translation);
}

TEST(Describe, OneLineFromIdAndVersions) {
  EXPECT_EQ(describe({"M1", "INDEMIND", "1.0", "H2", "", "", "", ""}),
            "INDEMIND module M1 (firmware 1.0, hardware H2)");
  EXPECT_EQ(describe({"M1", "", "", "H2", "", "", "", ""}), "INDEMIND module M1 (hardware H2)");
  EXPECT_EQ(describe({"", "", "2.1", "", "", "", "", ""}), "INDEMIND module (firmware 2.1)");
  EXPECT_EQ(describe(ModuleInfo{}), "INDEMIND module");
  // Built by hand, not through the parser: control bytes and long strings stay harmless.
  const std::string d = describe({"a\nb", "", std::string(100, '9'), "\x1b[2J", "", "", "", ""});
  EXPECT_EQ(d, "INDEMIND module a?b (firmware " + std::string(32, '9') + ", hardware ?[2J)");
}

TEST(Describe, UnterminatedAndGarbageStringsFromFlash) {
  std::vector<std::uint8_t> blob = encode_calibration_blob(module_of(make_rig()));
  constexpr std::size_t kInfo = 1312;
  for (std::size_t i = 0; i < 32; ++i) blob[kInfo + i] = static_cast<std::uint8_t>('A' + i % 26);
  for (std::size_t i = 0; i < 32; ++i)
    blob[kInfo + 32 + i] = 'Z';  // designer follows, unterminated
  const std::uint8_t firmware[] = {'1', '.', '2', 0x07, 0xC3, 0xA9, ' ', ' ', 0, 'x'};
  std::copy(std::begin(firmware), std::end(firmware), blob.begin() + kInfo + 64);
  std::fill(blob.begin() + kInfo + 96, blob.begin() + kInfo + 128, 0xFF);  // erased
  const ModuleInfo info = parse_calibration_blob(blob).info;
  EXPECT_EQ(describe(info),
            "INDEMIND module ABCDEFGHIJKLMNOPQRSTUVWXYZABCDEF (firmware 1.2???, "
            "hardware " +
                std::string(32, '?') + ")");
}

}  // namespace
}  // namespace dco::indemind
