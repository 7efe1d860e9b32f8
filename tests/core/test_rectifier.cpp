#include "dco/core/rectifier.hpp"

#include <cmath>
#include <optional>
#include <regex>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "dco/core/error.hpp"
#include "support/example_rigs.hpp"
#include "test_support.hpp"

namespace dco {
namespace {

// Rigs are checked by photographing single bright dots at known 3D points with the raw cameras
// (OpenCV's own projection, distortion included), rectifying, and measuring where the dots land.

cv::Mat rvec_of(const std::array<double, 9>& r) {
  cv::Mat rv;
  cv::Rodrigues(cv::Mat(3, 3, CV_64F, const_cast<double*>(r.data())), rv);
  return rv;
}

cv::Point2d project(const CameraIntrinsics& c, const cv::Point3d& p, const cv::Mat& rvec,
                    const cv::Mat& tvec) {
  const cv::Mat k = (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
  std::vector<cv::Point2d> out;
  if (c.model == CameraModel::kKannalaBrandt)
    cv::fisheye::projectPoints(std::vector<cv::Point3d>{p}, out, rvec, tvec, k, c.distortion);
  else
    cv::projectPoints(std::vector<cv::Point3d>{p}, rvec, tvec, k, c.distortion, out);
  return out[0];
}

void draw_dot(Image<std::uint8_t>& img, cv::Point2d at) {
  img.fill(0);
  constexpr double kSigma = 1.5;
  for (int y = static_cast<int>(at.y) - 7; y <= static_cast<int>(at.y) + 8; ++y)
    for (int x = static_cast<int>(at.x) - 7; x <= static_cast<int>(at.x) + 8; ++x) {
      if (x < 0 || y < 0 || x >= img.width() || y >= img.height()) continue;
      const double r2 = (x - at.x) * (x - at.x) + (y - at.y) * (y - at.y);
      const double v = 250.0 * std::exp(-r2 / (2 * kSigma * kSigma));
      for (int c = 0; c < img.channels(); ++c) img.at(x, y, c) = static_cast<std::uint8_t>(v + 0.5);
    }
}

// Intensity-weighted centroid around the brightest pixel; nothing if the dot left the image.
std::optional<cv::Point2d> find_dot(const Image<std::uint8_t>& img) {
  int bx = 0, by = 0, best = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      if (img.at(x, y) > best) {
        best = img.at(x, y);
        bx = x;
        by = y;
      }
  if (best < 40 || bx < 8 || by < 8 || bx >= img.width() - 8 || by >= img.height() - 8)
    return std::nullopt;
  double sw = 0, sx = 0, sy = 0;
  for (int y = by - 6; y <= by + 6; ++y)
    for (int x = bx - 6; x <= bx + 6; ++x) {
      const double w = img.at(x, y);
      sw += w;
      sx += w * x;
      sy += w * y;
    }
  return cv::Point2d(sx / sw, sy / sw);
}

struct RigResult {
  int measured = 0;
  double max_dy = 0;
  double max_disparity_error = 0;
};

// For each point: |row difference| and |disparity - expected|, where the expected disparity is
// f*B/Z with Z the depth along the rectified optical axis. The rectified left camera only rotates
// the raw one, so Z follows from the point's distance |P| and the ray through the measured pixel.
RigResult check_rig(const StereoCalibration& calib, const std::vector<cv::Point3d>& points,
                    int channels = 1) {
  const Rectifier rect(calib);
  const RectifiedGeometry& g = rect.geometry();
  const cv::Mat zero = cv::Mat::zeros(3, 1, CV_64F);
  const cv::Mat r = rvec_of(calib.rotation);
  const cv::Mat t(3, 1, CV_64F, const_cast<double*>(calib.translation.data()));
  Image<std::uint8_t> raw_l(calib.left.width, calib.left.height, channels);
  Image<std::uint8_t> raw_r(calib.right.width, calib.right.height, channels);
  Image<std::uint8_t> out_l, out_r;
  RigResult res;
  for (const cv::Point3d& p : points) {
    draw_dot(raw_l, project(calib.left, p, zero, zero));
    draw_dot(raw_r, project(calib.right, p, r, t));
    rect.rectify(raw_l.cview(), raw_r.cview(), out_l, out_r);
    EXPECT_EQ(out_l.channels(), channels);
    const auto l = find_dot(out_l), rr = find_dot(out_r);
    if (!l || !rr) continue;
    ++res.measured;
    const double ray = std::hypot((l->x - g.cx_left) / g.f, (l->y - g.cy) / g.f, 1.0);
    const double z = std::sqrt(p.dot(p)) / ray;
    const double expected = g.f * g.baseline_m / z - g.doffs();
    res.max_dy = std::max(res.max_dy, std::abs(l->y - rr->y));
    res.max_disparity_error = std::max(res.max_disparity_error, std::abs(l->x - rr->x - expected));
  }
  return res;
}

std::vector<cv::Point3d> grid(std::initializer_list<double> xs, std::initializer_list<double> ys,
                              std::initializer_list<double> zs) {
  std::vector<cv::Point3d> pts;
  for (double z : zs)
    for (double y : ys)
      for (double x : xs) pts.emplace_back(x * z, y * z, z);
  return pts;
}

using test::kannala_brandt_rig;
using test::pinhole_rig;

TEST(Rectifier, PinholeRigAlignsRowsAndDisparity) {
  const StereoCalibration calib = pinhole_rig();
  const Rectifier rect(calib);
  EXPECT_TRUE(rect.needs_remap());
  const RectifiedGeometry& g = rect.geometry();
  EXPECT_EQ(g.width, 640);
  EXPECT_EQ(g.height, 480);
  EXPECT_EQ(g.cx_left, g.cx_right);
  EXPECT_GT(g.f, 400);
  EXPECT_NEAR(g.baseline_m, std::hypot(0.1, 0.002, 0.001), 1e-9);

  const auto pts = grid({-0.4, -0.2, 0, 0.2, 0.4}, {-0.3, 0, 0.3}, {1.0, 3.0});
  const RigResult r = check_rig(calib, pts);
  EXPECT_GE(r.measured, static_cast<int>(pts.size()) * 8 / 10);
  EXPECT_LT(r.max_dy, 0.5);
  EXPECT_LT(r.max_disparity_error, 0.3);
}

TEST(Rectifier, PinholeRigInColour) {
  const auto pts = grid({-0.2, 0.2}, {0}, {2.0});
  const RigResult r = check_rig(pinhole_rig(), pts, 3);
  EXPECT_EQ(r.measured, 2);
  EXPECT_LT(r.max_dy, 0.5);
}

TEST(Rectifier, KannalaBrandtRigAlignsRowsAndDisparity) {
  const StereoCalibration calib = kannala_brandt_rig();
  const Rectifier rect(calib);
  const RectifiedGeometry& g = rect.geometry();
  EXPECT_EQ(g.cx_left, g.cx_right);
  EXPECT_GT(g.f, 0);
  EXPECT_NEAR(g.baseline_m, std::hypot(0.08, 0.001, 0.0005), 1e-9);

  const auto pts = grid({-0.4, -0.2, 0, 0.2, 0.4}, {-0.3, 0, 0.3}, {1.0, 3.0});
  const RigResult r = check_rig(calib, pts);
  EXPECT_GE(r.measured, static_cast<int>(pts.size()) * 8 / 10);
  EXPECT_LT(r.max_dy, 0.5);
  EXPECT_LT(r.max_disparity_error, 0.3);
}

TEST(Rectifier, PrecomputedKittiRectification) {
  const StereoCalibration calib = load_calibration(test::source_dir() / "tests" / "core" / "data" /
                                                   "kitti_calib_cam_to_cam.txt");
  const Rectifier rect(calib);
  EXPECT_TRUE(rect.needs_remap());
  EXPECT_EQ(rect.geometry().width, 1242);  // the rectified size, not the raw 1392x512
  EXPECT_EQ(rect.geometry().height, 375);
  EXPECT_EQ(rect.geometry().f, calib.rectified.f);
  EXPECT_EQ(rect.geometry().baseline_m, calib.rectified.baseline_m);

  const auto pts = grid({-0.5, -0.25, 0, 0.25, 0.5}, {-0.15, 0, 0.15}, {3.0, 8.0});
  const RigResult r = check_rig(calib, pts);
  EXPECT_GE(r.measured, static_cast<int>(pts.size()) * 8 / 10);
  EXPECT_LT(r.max_dy, 0.5);
  EXPECT_LT(r.max_disparity_error, 0.3);
}

TEST(Rectifier, PassThroughForRectifiedCalibration) {
  const StereoCalibration calib =
      load_calibration(test::data_dir() / "middlebury2014" / "Motorcycle" / "calib.txt");
  const Rectifier rect(calib);
  EXPECT_FALSE(rect.needs_remap());
  EXPECT_EQ(rect.geometry().cx_right, calib.rectified.cx_right);
  Image<std::uint8_t> l(741, 497, 3), r(741, 497, 3), lo, ro;
  for (int y = 0; y < 497; ++y)
    for (int x = 0; x < 741; ++x)
      for (int c = 0; c < 3; ++c) {
        l.at(x, y, c) = static_cast<std::uint8_t>(x * 7 + y * 3 + c);
        r.at(x, y, c) = static_cast<std::uint8_t>(x + y * 11 + c);
      }
  rect.rectify(l.cview(), r.cview(), lo, ro);
  ASSERT_EQ(lo.width(), 741);
  ASSERT_EQ(ro.channels(), 3);
  for (int y = 0; y < 497; y += 13)
    for (int x = 0; x < 741; x += 7) {
      ASSERT_EQ(lo.at(x, y, 2), l.at(x, y, 2));
      ASSERT_EQ(ro.at(x, y, 1), r.at(x, y, 1));
    }
  Image<std::uint8_t> small(640, 480);
  EXPECT_THROW(rect.rectify(small.cview(), small.cview(), lo, ro), Error);
}

TEST(Rectifier, PassThroughOfUnknownSizeTakesAnySize) {
  test::TempDir dir;
  const auto src = test::data_dir() / "karlsruhe_sequences" / "2010_03_09_drive_0023" / "calib.txt";
  test::write_file(dir / "calib.txt",
                   std::regex_replace(test::read_file(src), std::regex("\nroi: [^\n]*"), ""));
  const Rectifier rect(load_calibration(dir / "calib.txt"));
  Image<std::uint8_t> a(100, 40), b(100, 40), c(90, 40), lo, ro;
  a.fill(1);
  b.fill(2);
  rect.rectify(a.cview(), b.cview(), lo, ro);
  EXPECT_EQ(lo.width(), 100);
  EXPECT_EQ(ro.at(99, 39), 2);
  EXPECT_THROW(rect.rectify(a.cview(), c.cview(), lo, ro), Error);  // left and right differ
}

TEST(Rectifier, WrongInputSizeIsAnError) {
  const Rectifier rect(pinhole_rig());
  Image<std::uint8_t> good(640, 480), bad(320, 240), lo, ro;
  try {
    rect.rectify(bad.cview(), good.cview(), lo, ro);
    ADD_FAILURE() << "a 320x240 image was accepted";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("320x240"), std::string::npos) << msg;
    EXPECT_NE(msg.find("640x480"), std::string::npos) << msg;
  }
  EXPECT_THROW(rect.rectify(good.cview(), bad.cview(), lo, ro), Error);
  Image<std::uint8_t> two(640, 480, 2);
  EXPECT_THROW(rect.rectify(two.cview(), two.cview(), lo, ro), Error);
}

TEST(Rectifier, SteadyStateDoesNotAllocate) {
  const Rectifier rect(pinhole_rig());
  Image<std::uint8_t> l(640, 480), r(640, 480);
  l.fill(100);
  r.fill(100);
  Image<std::uint8_t> lo, ro;
  rect.rectify(l.cview(), r.cview(), lo, ro);
  const std::uint8_t* lp = lo.data();
  const std::uint8_t* rp = ro.data();
  rect.rectify(l.cview(), r.cview(), lo, ro);
  EXPECT_EQ(lo.data(), lp);
  EXPECT_EQ(ro.data(), rp);
  EXPECT_FALSE(lo.resize(rect.geometry().width, rect.geometry().height));
  EXPECT_FALSE(ro.resize(rect.geometry().width, rect.geometry().height));
  EXPECT_EQ(lo.at(320, 240), 100);  // the remap wrote into the caller's buffer
}

TEST(Rectifier, RefusesVerticalAndSwappedRigs) {
  StereoCalibration c = pinhole_rig();
  c.translation = {0.001, -0.1, 0};
  EXPECT_THROW(Rectifier{c}, Error);
  c.translation = {0.1, 0, 0};  // "right" camera to the left
  EXPECT_THROW(Rectifier{c}, Error);
  c.translation = {0, 0, 0};
  EXPECT_THROW(Rectifier{c}, Error);
}

// Distortion far from any lens rectifies to a focal length orders of magnitude off, where every
// disparity rounds to 0: an error, not a map of zeros.
TEST(Rectifier, RefusesADegenerateRectification) {
  StereoCalibration c = pinhole_rig();
  c.left.distortion = c.right.distortion = {1e6, 0, 0, 0};
  try {
    Rectifier r(c);
    ADD_FAILURE() << "rectified to f = " << r.geometry().f;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("the rectification is degenerate"), std::string::npos)
        << e.what();
  }
  c.left.distortion = c.right.distortion = {-0.1, 0.01, 0, 0};
  EXPECT_NO_THROW(Rectifier{c});
  // k1 = -1 turns the radial term back at r = 0.58, inside the image's 0.8: the corners would
  // show the camera's image mirrored, though most of them still fall on it.
  for (const double k1 : {-1.0, -2.0}) {
    c.left.distortion = c.right.distortion = {k1, 0, 0, 0};
    try {
      Rectifier r(c);
      ADD_FAILURE() << "k1 " << k1 << " rectified to f = " << r.geometry().f;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("folds its image back on itself"), std::string::npos)
          << e.what();
    }
  }
  // A fisheye lens's coefficients that leave no focal length: said as such, not as swapped
  // cameras.
  StereoCalibration fisheye = test::kannala_brandt_rig();
  fisheye.left.distortion = fisheye.right.distortion = {-0.7, 0, 0, 0};
  try {
    Rectifier r(fisheye);
    ADD_FAILURE() << "rectified to f = " << r.geometry().f;
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).find("swap"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("distortion"), std::string::npos) << e.what();
  }
}

// A precomputed rectification gets the checks of one dco computes: a focal length typed in the
// wrong unit, an output far larger than the camera's, or one that mostly misses the camera's
// image is refused instead of rectifying to black frames.
TEST(Rectifier, RefusesAPrecomputedRectificationThatMissesTheCamera) {
  const StereoCalibration kitti = load_calibration(test::source_dir() / "tests" / "core" / "data" /
                                                   "kitti_calib_cam_to_cam.txt");
  const auto refused = [](const StereoCalibration& c, const std::string& why) {
    try {
      Rectifier r(c);
      ADD_FAILURE() << "rectified to " << r.geometry().width << "x" << r.geometry().height
                    << ", f = " << r.geometry().f;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  };
  StereoCalibration c = kitti;
  c.rectified.f /= 100;
  refused(c, "the rectification is degenerate (focal length 6.906 px");
  // The same mistake in a P_rect carries into the baseline taken from it (f B stays): 53 m is
  // no stereo rig's.
  c.rectified.baseline_m *= 100;
  refused(c, "rectified baseline must be within 1 mm..10 m");
  c = kitti;
  c.rectified.width = c.rectified.height = 16384;
  refused(c, "rectified images of 16384x16384 from a camera of 1392x512");
  // Both principal points moved alike far past the image (the calibration's own check; so is
  // their difference, doffs, as wide as the image), then the right one by most of the image's
  // width, which still lies within half a side of it.
  c = kitti;
  c.rectified.cx_left += 2000;
  c.rectified.cx_right += 2000;
  refused(c, "lies more than half the image's side outside the 1242x375 image");
  c = kitti;
  c.rectified.cx_right -= 1100;
  refused(c, "of the rectified right image falls on the camera's");
  c = kitti;
  c.rectified.cx_right -= 2000;
  refused(c, "rectified principal points differ by -2000 px in x");
  EXPECT_NO_THROW(Rectifier{kitti});
}

// A pass-through still checks that the images are of the calibrated size.
TEST(Rectifier, PassThroughChecksTheCalibratedSize) {
  StereoCalibration c = pinhole_rig();
  const Rectifier raw(c);
  c.is_rectified = true;
  c.rectified = raw.geometry();
  c.left.width = c.right.width = c.rectified.width;
  c.left.height = c.right.height = c.rectified.height;
  c.left.distortion.clear();
  c.right.distortion.clear();
  const Rectifier pass(c);
  ASSERT_FALSE(pass.needs_remap());
  Image<std::uint8_t> half(c.rectified.width / 2, c.rectified.height / 2);
  half.fill(0);
  try {
    pass.check_inputs(half.cview(), half.cview());
    ADD_FAILURE() << "took images of half the calibrated size";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("but the calibration is for"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace dco
