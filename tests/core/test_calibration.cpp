#include "dco/core/calibration.hpp"

#include <array>
#include <cmath>
#include <iterator>
#include <limits>
#include <numbers>
#include <regex>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "test_support.hpp"

namespace dco {
namespace {

const auto kMiddlebury = test::data_dir() / "middlebury2014" / "Motorcycle" / "calib.txt";
const auto kKarlsruhe =
    test::data_dir() / "karlsruhe_sequences" / "2010_03_09_drive_0023" / "calib.txt";
const auto kKitti = test::source_dir() / "tests" / "core" / "data" / "kitti_calib_cam_to_cam.txt";

// The message of the dco::Error that loading `text` (saved as `name`) throws, or "" if none.
std::string load_error(const test::TempDir& dir, const std::string& name, const std::string& text) {
  test::write_file(dir / name, text);
  try {
    load_calibration(dir / name);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

const std::string kRigToml = R"([left]
model = "pinhole"
width = 640
height = 480
fx = 500.0
fy = 500.0
cx = 320.0
cy = 240.0
distortion = [-0.1, 0.01, 0.0, 0.0]

[right]
model = "pinhole"
width = 640
height = 480
fx = 500.0
fy = 500.0
cx = 320.0
cy = 240.0

[extrinsics]
rotation = [1, 0, 0, 0, 1, 0, 0, 0, 1]
translation = [-0.1, 0, 0]
)";

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto pos = text.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  return text.replace(pos, from.size(), to);
}

void expect_same(const StereoCalibration& a, const StereoCalibration& b) {
  const CameraIntrinsics* ca[2] = {&a.left, &a.right};
  const CameraIntrinsics* cb[2] = {&b.left, &b.right};
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(ca[i]->model, cb[i]->model);
    EXPECT_EQ(ca[i]->width, cb[i]->width);
    EXPECT_EQ(ca[i]->height, cb[i]->height);
    EXPECT_EQ(ca[i]->fx, cb[i]->fx);
    EXPECT_EQ(ca[i]->fy, cb[i]->fy);
    EXPECT_EQ(ca[i]->cx, cb[i]->cx);
    EXPECT_EQ(ca[i]->cy, cb[i]->cy);
    EXPECT_EQ(ca[i]->distortion, cb[i]->distortion);
  }
  EXPECT_EQ(a.rotation, b.rotation);
  EXPECT_EQ(a.translation, b.translation);
  EXPECT_EQ(a.has_rectification, b.has_rectification);
  EXPECT_EQ(a.rect_rotation_left, b.rect_rotation_left);
  EXPECT_EQ(a.rect_rotation_right, b.rect_rotation_right);
  EXPECT_EQ(a.is_rectified, b.is_rectified);
  EXPECT_EQ(a.rectified.width, b.rectified.width);
  EXPECT_EQ(a.rectified.height, b.rectified.height);
  EXPECT_EQ(a.rectified.f, b.rectified.f);
  EXPECT_EQ(a.rectified.cx_left, b.rectified.cx_left);
  EXPECT_EQ(a.rectified.cx_right, b.rectified.cx_right);
  EXPECT_EQ(a.rectified.cy, b.rectified.cy);
  EXPECT_EQ(a.rectified.baseline_m, b.rectified.baseline_m);
}

TEST(Geometry, DepthAndDisparityAreInverse) {
  RectifiedGeometry g;
  g.f = 500;
  g.baseline_m = 0.1;
  EXPECT_DOUBLE_EQ(g.depth_from_disparity(25), 2.0);
  EXPECT_DOUBLE_EQ(g.disparity_from_depth(2.0), 25);
  EXPECT_EQ(g.depth_from_disparity(0), std::numeric_limits<double>::infinity());
  EXPECT_EQ(g.depth_from_disparity(-3), std::numeric_limits<double>::infinity());
  g.cx_left = 100;
  g.cx_right = 110;  // doffs 10
  EXPECT_DOUBLE_EQ(g.doffs(), 10);
  EXPECT_DOUBLE_EQ(g.depth_from_disparity(15), 2.0);
  EXPECT_DOUBLE_EQ(g.disparity_from_depth(2.0), 15);
  EXPECT_EQ(g.depth_from_disparity(-10), std::numeric_limits<double>::infinity());
  EXPECT_DOUBLE_EQ(g.depth_from_disparity(-9), 50.0);
}

TEST(Calibration, LoadsMiddlebury) {
  const StereoCalibration c = load_calibration(kMiddlebury);
  EXPECT_TRUE(c.is_rectified);
  EXPECT_FALSE(c.has_rectification);
  EXPECT_EQ(c.rectified.width, 741);
  EXPECT_EQ(c.rectified.height, 497);
  EXPECT_DOUBLE_EQ(c.rectified.f, 999.421);
  EXPECT_DOUBLE_EQ(c.rectified.cx_left, 294.182);
  EXPECT_DOUBLE_EQ(c.rectified.cx_right, 326.96);
  EXPECT_DOUBLE_EQ(c.rectified.cy, 252.932);
  EXPECT_DOUBLE_EQ(c.rectified.baseline_m, 0.193001);
  EXPECT_NEAR(c.rectified.doffs(), 32.778, 1e-9);
  EXPECT_EQ(c.left.width, 741);
  EXPECT_DOUBLE_EQ(c.right.cx, 326.96);
  EXPECT_TRUE(c.left.distortion.empty());
  EXPECT_DOUBLE_EQ(c.translation[0], -0.193001);
  EXPECT_EQ(c.source, kMiddlebury.string());
  // Middlebury's own formula: Z[mm] = baseline[mm] * f / (d + doffs).
  for (double d : {9.5, 30.0, 62.9})
    EXPECT_NEAR(c.rectified.depth_from_disparity(d), 193.001 * 999.421 / (d + 32.778) / 1000.0,
                1e-12);
}

TEST(Calibration, DetectsMiddleburyByContentNotLineOrder) {
  test::TempDir dir;
  const std::string text = test::read_file(kMiddlebury);
  const auto cam1 = text.find("cam1=");
  // "# note", then everything from cam1 on, then the cam0 line last.
  test::write_file(dir / "reordered.conf",
                   "# copied from MiddEval3\n" + text.substr(cam1) + text.substr(0, cam1));
  const StereoCalibration c = load_calibration(dir / "reordered.conf");
  EXPECT_DOUBLE_EQ(c.rectified.cx_left, 294.182);
  EXPECT_DOUBLE_EQ(c.rectified.cx_right, 326.96);
}

// A byte-order mark before the first line does not hide the format.
TEST(Calibration, FilesStartingWithAByteOrderMarkLoad) {
  test::TempDir dir;
  test::write_file(dir / "bom.txt", "\xEF\xBB\xBF" + test::read_file(kMiddlebury));
  EXPECT_DOUBLE_EQ(load_calibration(dir / "bom.txt").rectified.cx_right, 326.96);
  test::write_file(dir / "bom_kitti.txt", "\xEF\xBB\xBF" + test::read_file(kKitti));
  EXPECT_TRUE(load_calibration(dir / "bom_kitti.txt").has_rectification);
  test::write_file(dir / "bom.toml", "\xEF\xBB\xBF" + kRigToml);
  EXPECT_DOUBLE_EQ(load_calibration(dir / "bom.toml").translation[0], -0.1);
}

TEST(Calibration, LoadsKarlsruhe) {
  const StereoCalibration c = load_calibration(kKarlsruhe);
  EXPECT_TRUE(c.is_rectified);
  EXPECT_EQ(c.rectified.width, 1344);  // the size of the images next to the file
  EXPECT_EQ(c.rectified.height, 372);
  EXPECT_DOUBLE_EQ(c.rectified.f, 645.2401);
  EXPECT_DOUBLE_EQ(c.rectified.cx_left, 635.9587);
  EXPECT_DOUBLE_EQ(c.rectified.cx_right, 635.9587);
  EXPECT_DOUBLE_EQ(c.rectified.cy, 194.1291);
  EXPECT_DOUBLE_EQ(c.rectified.baseline_m, 368.2632 / 645.2401);
  EXPECT_NEAR(c.rectified.depth_from_disparity(10), 36.82632, 1e-9);
  EXPECT_EQ(c.left.height, 372);
}

TEST(Calibration, KarlsruheWithoutRoiHasUnknownSize) {
  test::TempDir dir;
  std::string text = test::read_file(kKarlsruhe);
  text = std::regex_replace(text, std::regex("\nroi: [^\n]*"), "");
  test::write_file(dir / "calib.txt", text);
  const StereoCalibration c = load_calibration(dir / "calib.txt");
  EXPECT_TRUE(c.is_rectified);
  EXPECT_EQ(c.rectified.width, 0);
  EXPECT_EQ(c.rectified.height, 0);
  EXPECT_DOUBLE_EQ(c.rectified.f, 645.2401);
}

TEST(Calibration, LoadsKittiCamToCam) {
  const StereoCalibration c = load_calibration(kKitti);
  EXPECT_FALSE(c.is_rectified);
  EXPECT_TRUE(c.has_rectification);
  EXPECT_EQ(c.left.width, 1392);
  EXPECT_EQ(c.left.height, 512);
  EXPECT_DOUBLE_EQ(c.left.fx, 959.8);
  EXPECT_DOUBLE_EQ(c.left.fy, 958.0);
  EXPECT_DOUBLE_EQ(c.right.fx, 903.7);
  ASSERT_EQ(c.left.distortion.size(), 5u);
  EXPECT_DOUBLE_EQ(c.left.distortion[0], -0.37);
  EXPECT_DOUBLE_EQ(c.right.distortion[4], -0.06);
  EXPECT_EQ(c.rectified.width, 1242);
  EXPECT_EQ(c.rectified.height, 375);
  EXPECT_DOUBLE_EQ(c.rectified.f, 690.6366);
  EXPECT_DOUBLE_EQ(c.rectified.cx_left, 596.5517);
  EXPECT_DOUBLE_EQ(c.rectified.cy, 162.1902);
  EXPECT_DOUBLE_EQ(c.rectified.baseline_m, (41.4382 + 326.6791) / 690.6366);
  EXPECT_DOUBLE_EQ(c.rect_rotation_left[0], 0.99954);
  EXPECT_DOUBLE_EQ(c.rect_rotation_right[8], 0.9999255);
  // The rig the fixture was made from: T = T_03 - R T_02 with R = R_03 R_02^T.
  EXPECT_NEAR(c.translation[0], -0.5329278, 2e-6);
  EXPECT_NEAR(c.translation[1], 0.007103519, 2e-6);
  EXPECT_NEAR(c.translation[2], -0.006234079, 2e-6);
  EXPECT_NEAR(c.rotation[1], 0.006935632, 2e-6);
  EXPECT_NEAR(c.rotation[5], 0.006919492, 2e-6);
}

// KITTI's published colour pairs sit a few millimetres off the line between their centres: the
// last columns of P_rect_02 / P_rect_03 carry f ty + cy tz and tz, as here (sizes of the
// 2011_09_26 drive's file).
TEST(Calibration, KittiColourPairSlightlyOffItsBaselineLoads) {
  test::TempDir dir;
  std::string text = test::read_file(kKitti);
  // Sets numbers i (0-based) of a "key: numbers" line.
  const auto set_numbers = [&text](const std::string& key,
                                   const std::vector<std::pair<int, std::string>>& values) {
    const std::size_t begin = text.find(key + ": ") + key.size() + 2;
    const std::size_t end = text.find('\n', begin);
    std::istringstream in(text.substr(begin, end - begin));
    std::vector<std::string> numbers{std::istream_iterator<std::string>(in), {}};
    for (const auto& [i, v] : values) numbers[static_cast<std::size_t>(i)] = v;
    std::string line;
    for (const std::string& n : numbers) line += (line.empty() ? "" : " ") + n;
    text.replace(begin, end - begin, line);
  };
  set_numbers("P_rect_02", {{7, "2.163791e-01"}, {11, "2.745884e-03"}});
  set_numbers("P_rect_03", {{7, "2.199936e+00"}, {11, "2.729905e-03"}});
  ASSERT_NE(text.find("2.729905e-03"), std::string::npos);
  test::write_file(dir / "cam_to_cam.txt", text);
  const StereoCalibration c = load_calibration(dir / "cam_to_cam.txt");
  const double f = 690.6366, cx = 596.5517;
  EXPECT_NEAR(c.rectified.baseline_m,
              ((41.4382 - cx * 2.745884e-3) - (-326.6791 - cx * 2.729905e-3)) / f, 1e-12);

  // The same pair 5 % of its baseline apart vertically is not side by side.
  const std::string apart =
      std::regex_replace(text, std::regex("2\\.199936e\\+00"), "1.860000e+01");
  const std::string msg = load_error(dir, "ki_apart.txt", apart);
  EXPECT_NE(msg.find("ki_apart.txt:19: P_rect_02 and P_rect_03 place the cameras apart "
                     "vertically or in depth by more than 2 % of their baseline"),
            std::string::npos)
      << msg;

  // A skew, or a term in the third row, has no place in a rectified projection.
  for (const int i : {1, 4, 8, 9}) {
    std::string skewed = text;
    set_numbers("P_rect_03", {{i, "5.000000e-01"}});
    std::swap(skewed, text);
    const std::string why = load_error(dir, "ki_skew.txt", skewed);
    EXPECT_NE(why.find("ki_skew.txt:19: P_rect_03 is not a rectified projection"),
              std::string::npos)
        << i << ": " << why;
  }
}

TEST(Calibration, KittiExtrinsicsFollowFromRectificationAlone) {
  test::TempDir dir;
  std::string text = test::read_file(kKitti);
  text = std::regex_replace(text, std::regex("\n[RT]_0[23]: [^\n]*"), "");
  ASSERT_EQ(text.find("T_02"), std::string::npos);
  test::write_file(dir / "cam_to_cam.txt", text);
  const StereoCalibration derived = load_calibration(dir / "cam_to_cam.txt");
  const StereoCalibration full = load_calibration(kKitti);
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(derived.rotation[i], full.rotation[i], 1e-5) << i;
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(derived.translation[i], full.translation[i], 1e-5) << i;
}

TEST(Calibration, TomlRoundTrip) {
  test::TempDir dir;
  StereoCalibration c;
  c.left = {CameraModel::kPinhole,
            640,
            480,
            501.25,
            499.75,
            319.5,
            241.125,
            {-0.123456789, 0.0123, 1e-4, -2e-4, 0.001}};
  c.right = {CameraModel::kPinhole,
             640,
             480,
             503.1,
             502.9,
             322.2,
             238.8,
             {-0.11, 0.02, 0, 0, 0, 0.001, 0.0002, -0.0003}};
  const double a = 0.0123, ca = std::cos(a), sa = std::sin(a);
  c.rotation = {ca, 0, sa, 0, 1, 0, -sa, 0, ca};
  c.translation = {-0.0641234567, 0.0002, -0.0011};
  c.source = "in memory";
  save_calibration(dir / "rig.toml", c);
  const StereoCalibration back = load_calibration(dir / "rig.toml");
  expect_same(c, back);
  EXPECT_EQ(back.source, (dir / "rig.toml").string());
}

TEST(Calibration, TomlRoundTripOfLoadedFormats) {
  test::TempDir dir;
  for (const auto& path : {kMiddlebury, kKarlsruhe, kKitti}) {
    const StereoCalibration c = load_calibration(path);
    save_calibration(dir / "copy.toml", c);
    SCOPED_TRACE(path.string());
    expect_same(c, load_calibration(dir / "copy.toml"));
  }
}

// toml++ reads subnormal numbers back only approximately: they are written as 0, so what is saved
// reads back to what is written.
TEST(Calibration, TomlWritesSubnormalCoefficientsAsZero) {
  test::TempDir dir;
  StereoCalibration c;
  c.left = c.right = {CameraModel::kPinhole, 64, 48, 50, 50, 32, 24, {6.05e-319, -1e-310, 0, 0}};
  c.translation = {-0.1, 0, 0};
  const std::string toml = calibration_to_toml(c);
  const StereoCalibration back = calibration_from_toml(toml, "text");
  EXPECT_EQ(back.left.distortion[0], 0.0);
  EXPECT_EQ(back.left.distortion[1], 0.0);
  EXPECT_TRUE(std::signbit(back.left.distortion[1]));
  EXPECT_EQ(calibration_to_toml(back), toml);
}

TEST(Calibration, TomlKannalaBrandtAndRodrigues) {
  test::TempDir dir;
  std::string text =
      replaced(kRigToml, "rotation = [1, 0, 0, 0, 1, 0, 0, 0, 1]", "rotation = [0, 0, 0.1]");
  text = replaced(text, "model = \"pinhole\"", "model = \"kannala_brandt\"");
  text =
      replaced(text, "distortion = [-0.1, 0.01, 0.0, 0.0]", "distortion = [0.05, -0.01, 0.002, 0]");
  test::write_file(dir / "kb.toml", text);
  const StereoCalibration c = load_calibration(dir / "kb.toml");
  EXPECT_EQ(c.left.model, CameraModel::kKannalaBrandt);
  EXPECT_EQ(c.right.model, CameraModel::kPinhole);
  EXPECT_NEAR(c.rotation[0], std::cos(0.1), 1e-12);
  EXPECT_NEAR(c.rotation[1], -std::sin(0.1), 1e-12);
  EXPECT_NEAR(c.rotation[3], std::sin(0.1), 1e-12);
  EXPECT_DOUBLE_EQ(c.left.fx, 500.0);  // integers and floats both read as numbers
}

TEST(Calibration, TomlRectifiedOnlyDerivesCameras) {
  test::TempDir dir;
  test::write_file(dir / "r.toml",
                   "[rectified]\nwidth = 100\nheight = 50\nf = 80\ncx_left = 49.5\n"
                   "cx_right = 52\ncy = 24.5\nbaseline_m = 0.05\n");
  const StereoCalibration c = load_calibration(dir / "r.toml");
  EXPECT_TRUE(c.is_rectified);
  EXPECT_EQ(c.left.width, 100);
  EXPECT_DOUBLE_EQ(c.right.cx, 52);
  EXPECT_DOUBLE_EQ(c.translation[0], -0.05);
  EXPECT_DOUBLE_EQ(c.rectified.doffs(), 2.5);
}

TEST(Calibration, DocumentationExamplesLoad) {
  test::TempDir dir;
  const std::string doc = test::read_file(test::source_dir() / "docs" / "calibration.md");
  const std::regex block("```toml\n([^`]*)```");
  int n = 0;
  for (auto it = std::sregex_iterator(doc.begin(), doc.end(), block); it != std::sregex_iterator();
       ++it, ++n) {
    const std::string name = "example" + std::to_string(n) + ".toml";
    test::write_file(dir / name, (*it)[1].str());
    EXPECT_NO_THROW(load_calibration(dir / name)) << (*it)[1].str();
  }
  EXPECT_GE(n, 2);
}

TEST(CalibrationErrors, NameTheFileAndLine) {
  test::TempDir dir;
  struct Case {
    std::string name, text, expected;
  };
  const Case cases[] = {
      {"missing.toml", replaced(kRigToml, "fx = 500.0\n", ""),
       "missing.toml:1: [left] is missing 'fx'"},
      {"bad_number.toml", replaced(kRigToml, "fy = 500.0", "fy = \"abc\""),
       "bad_number.toml:6: [left] fy must be a number"},
      {"unknown_key.toml",
       replaced(kRigToml, "cy = 240.0\ndistortion", "cy = 240.0\nfxx = 1\ndistortion"),
       "unknown_key.toml:9: unknown key 'fxx' in [left]"},
      {"unknown_section.toml", kRigToml + "\n[lens]\nx = 1\n",
       "unknown_section.toml:24: unknown section or key 'lens'"},
      {"syntax.toml", replaced(kRigToml, "width = 640\nheight", "width = = 640\nheight"),
       "syntax.toml:3:"},
      {"rotation.toml",
       replaced(kRigToml, "rotation = [1, 0, 0, 0, 1, 0, 0, 0, 1]",
                "rotation = [1, 0.2, 0, 0, 1, 0, 0, 0, 1]"),
       "rotation.toml: extrinsic rotation is not orthonormal"},
      {"reflection.toml",
       replaced(kRigToml, "rotation = [1, 0, 0, 0, 1, 0, 0, 0, 1]",
                "rotation = [-1, 0, 0, 0, 1, 0, 0, 0, 1]"),
       "reflection.toml: extrinsic rotation is a reflection"},
      {"baseline.toml", replaced(kRigToml, "translation = [-0.1, 0, 0]", "translation = [0, 0, 0]"),
       "baseline.toml: baseline is zero"},
      {"focal.toml", replaced(kRigToml, "fx = 500.0", "fx = -500.0"),
       "focal.toml: left camera: focal"},
      // Beyond what a camera can have: a subnormal focal length (which would not even survive
      // being written out), a baseline of 100 km, a principal point far off.
      {"focal_tiny.toml", replaced(kRigToml, "fx = 500.0", "fx = 6.05e-319"),
       "focal_tiny.toml: left camera: focal lengths must be within 1..1000000 px"},
      {"focal_huge.toml", replaced(kRigToml, "fy = 500.0", "fy = 5e7"),
       "focal_huge.toml: left camera: focal lengths must be within 1..1000000 px"},
      {"baseline_far.toml",
       replaced(kRigToml, "translation = [-0.1, 0, 0]", "translation = [-1e5, 0, 0]"),
       "baseline_far.toml: baseline 100000 m (the translation's length) is not within 1 mm..10 m "
       "(a stereo rig's; another unit?)"},
      // A baseline in the wrong unit: millimetres where metres go, metres where millimetres go.
      {"baseline_mm.toml",
       replaced(kRigToml, "translation = [-0.1, 0, 0]", "translation = [-100, 0, 0]"),
       "baseline_mm.toml: baseline 100 m (the translation's length) is not within 1 mm..10 m"},
      {"mb_metres.txt",
       replaced(test::read_file(kMiddlebury), "baseline=193.001", "baseline=0.193"),
       "mb_metres.txt: baseline 0.000193 m (the translation's length) is not within 1 mm..10 m"},
      {"centre.toml", replaced(kRigToml, "cx = 320.0", "cx = 3.2e8"),
       "centre.toml: left camera: principal point (320000000, 240) is more than 1000000 px"},
      {"mb_baseline.txt",
       replaced(test::read_file(kMiddlebury), "baseline=193.001", "baseline=1e-9"),
       "mb_baseline.txt: baseline 1e-12 m (the translation's length) is not within 1 mm..10 m (a "
       "stereo rig's; another unit?)"},
      {"mb_focal.txt",
       std::regex_replace(test::read_file(kMiddlebury), std::regex("999\\.421"), "0.5"),
       "mb_focal.txt: left camera: focal lengths must be within 1..1000000 px (fx 0.5, fy 0.5)"},
      {"distortion.toml", replaced(kRigToml, "[-0.1, 0.01, 0.0, 0.0]", "[-0.1, 0.01, 0.0]"),
       "distortion.toml: left camera: the pinhole model takes 0, 4, 5 or 8"},
      {"size.toml", replaced(kRigToml, "width = 640", "width = 0"),
       "size.toml: left camera: image size 0x480"},
      {"mismatch.toml",
       replaced(kRigToml, "[right]\nmodel = \"pinhole\"\nwidth = 640",
                "[right]\nmodel = \"pinhole\"\nwidth = 320"),
       "mismatch.toml: left images are 640x480 but right images are 320x480"},
      {"model.toml", replaced(kRigToml, "\"pinhole\"", "\"fisheye\""),
       "model.toml:2: [left] model must be"},
      {"width_float.toml", replaced(kRigToml, "width = 640", "width = 640.5"),
       "width_float.toml:3: [left] width must be an integer"},
      {"no_right.toml", kRigToml.substr(0, kRigToml.find("[right]")),
       "no_right.toml: missing section [right]"},
      {"empty.toml", "\n\n", "empty.toml: calibration file is empty"},
      // A rectified rig whose extrinsics say another baseline: which one the depth needs is
      // unknown (here 5 m against 0.1 m).
      {"two_baselines.toml",
       kRigToml + "\n[rectified]\nwidth = 640\nheight = 480\nf = 500\ncx_left = 320\n"
                  "cx_right = 320\ncy = 240\nbaseline_m = 5.0\n",
       "two_baselines.toml: rectified baseline 5 m differs from the translation's length 0.1 m"},
      // Principal points as far apart as the image is wide: a typo that would make every depth
      // infinite (or a few millimetres).
      {"doffs_wide.toml",
       kRigToml + "\n[rectified]\nwidth = 640\nheight = 480\nf = 500\ncx_left = 320\n"
                  "cx_right = -400\ncy = 240\nbaseline_m = 0.1\n",
       "doffs_wide.toml: rectified principal points differ by -720 px in x (cx_right - cx_left), "
       "not less than the image's width of 640 px: every depth would be infinite"},
      {"mb_doffs.txt", replaced(test::read_file(kMiddlebury), "doffs=32.778", "doffs=30"),
       "mb_doffs.txt:3: doffs 30 disagrees"},
      {"mb_number.txt", replaced(test::read_file(kMiddlebury), "baseline=193.001", "baseline=19x"),
       "mb_number.txt:4: '19x' in baseline is not a number"},
      {"mb_missing.txt", replaced(test::read_file(kMiddlebury), "cam1=", "cam9="),
       "mb_missing.txt: missing 'cam1'"},
      {"ka_count.txt", replaced(test::read_file(kKarlsruhe), " 0.000000e+00\nP2:", "\nP2:"),
       "ka_count.txt:13: P1_roi has 11 numbers, expected 12"},
      {"ki_missing.txt",
       std::regex_replace(test::read_file(kKitti), std::regex("P_rect_03: [^\n]*\n"), ""),
       "ki_missing.txt: missing 'P_rect_03'"},
      {"ki_garbage.txt", test::read_file(kKitti) + "this line is not a key\n",
       "ki_garbage.txt:20: expected 'key: values'"},
      {"unknown_keys.txt", "foo: 1 2 3\n",
       "unknown_keys.txt: unrecognised 'key: numbers' calibration"},
      // Which of two values was meant is unknown: neither wins.
      {"mb_twice.txt", test::read_file(kMiddlebury) + "baseline=0.1\n",
       "mb_twice.txt:13: baseline is given twice (first on line 4)"},
      {"ki_twice.txt", test::read_file(kKitti) + "S_02: 640 480\n",
       "ki_twice.txt:20: S_02 is given twice (first on line 4)"},
      {"mb_doffs_nan.txt", replaced(test::read_file(kMiddlebury), "doffs=32.778", "doffs=nan"),
       "mb_doffs_nan.txt:3: doffs nan disagrees"},
      {"mb_huge.txt", replaced(test::read_file(kMiddlebury), "width=741", "width=100000"),
       "mb_huge.txt: left camera: image size 100000x497 is not within 1..16384"},
      {"ki_srect.txt",
       std::regex_replace(test::read_file(kKitti), std::regex("S_rect_03: [^\n]*"),
                          "S_rect_03: 1.240000e+03 3.750000e+02"),
       "ki_srect.txt:17: S_rect_03 is 1240x375 but S_rect_02 is 1242x375"},
      {"ki_skew.txt",
       std::regex_replace(test::read_file(kKitti), std::regex("K_02: (\\S+) \\S+"), "K_02: $1 5.0"),
       "ki_skew.txt:5: K_02 is not a camera matrix [fx 0 cx; 0 fy cy; 0 0 1]"},
      {"turned.toml",
       replaced(kRigToml, "rotation = [1, 0, 0, 0, 1, 0, 0, 0, 1]",
                "rotation = [-1, 0, 0, 0, 1, 0, 0, 0, -1]"),
       "turned.toml: the cameras are turned 180.0 degrees apart (at most 60 for a stereo pair)"},
      {"forward.toml",
       replaced(kRigToml, "translation = [-0.1, 0, 0]", "translation = [-0.03, 0, 0.064]"),
       "forward.toml: the right camera sits 64.9 degrees in front of or behind the left"},
      {"huge.toml",
       replaced(replaced(kRigToml, "width = 640", "width = 20000"), "width = 640", "width = 20000"),
       "huge.toml: left camera: image size 20000x480 is not within 1..16384 px a side"},
  };
  for (const Case& c : cases) {
    const std::string msg = load_error(dir, c.name, c.text);
    EXPECT_NE(msg.find(c.expected), std::string::npos)
        << "file " << c.name << "\nexpected: " << c.expected << "\ngot: " << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;  // one line
  }
  try {
    load_calibration(dir / "does_not_exist.toml");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("does_not_exist.toml"), std::string::npos);
  }
}

// A rectified principal point far outside the image turns the rays depth is published with.
TEST(CalibrationErrors, ARectifiedPrincipalPointFarOutsideTheImageIsRefused) {
  test::TempDir dir;
  const std::string text =
      "cam0=[125 0 -5000; 0 125 -3000; 0 0 1]\n"
      "cam1=[125 0 -5000; 0 125 -3000; 0 0 1]\n"
      "doffs=0\nbaseline=60\nwidth=160\nheight=120\nndisp=32\n";
  const std::string msg = load_error(dir, "outside.txt", text);
  EXPECT_NE(msg.find("lies more than half the image's side outside the 160x120 image"),
            std::string::npos)
      << msg;
  std::string inside = text;
  for (const char* from : {"-5000", "-5000"}) inside.replace(inside.find(from), 5, "79.5");
  for (const char* from : {"-3000", "-3000"}) inside.replace(inside.find(from), 5, "59.5");
  EXPECT_EQ(load_error(dir, "inside.txt", inside), "");
}

// Rectifying rotations of other extrinsics (lines swapped, another calibration's) would leave the
// rows pixels apart at the edges: refused, while the file as written loads.
TEST(CalibrationErrors, RectifyingRotationsMustBelongToTheExtrinsics) {
  test::TempDir dir;
  const std::string text = test::read_file(kKitti);
  const auto line_of = [&text](const std::string& key) {
    const std::size_t begin = text.find(key + ": ");
    return text.substr(begin, text.find('\n', begin) - begin);
  };
  std::string swapped = text;
  const std::string left = line_of("R_rect_02"), right = line_of("R_rect_03");
  swapped.replace(swapped.find(left), left.size(), "R_rect_02" + right.substr(9));
  swapped.replace(swapped.find(right), right.size(), "R_rect_03" + left.substr(9));
  const std::string msg = load_error(dir, "swapped_rect.txt", swapped);
  EXPECT_NE(msg.find("the rectifying rotations"), std::string::npos) << msg;

  const StereoCalibration kitti = load_calibration(kKitti);
  EXPECT_NO_THROW(kitti.validate());
  // The cameras' rotation turned 1 degree about the optical axis.
  StereoCalibration turned = kitti;
  const double a = std::numbers::pi / 180;
  const std::array<double, 9> roll{
      std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double v = 0;
      for (int k = 0; k < 3; ++k) v += roll[3 * i + k] * kitti.rotation[3 * k + j];
      turned.rotation[3 * i + j] = v;
    }
  try {
    turned.validate();
    ADD_FAILURE() << "a rotation 1 degree off its rectification passed";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("leave the cameras turned 1.00 degrees apart"),
              std::string::npos)
        << e.what();
  }
  // The translation 2 degrees off the rectified x axis, and reversed.
  StereoCalibration tilted = kitti;
  const double b = std::hypot(kitti.translation[0], kitti.translation[1], kitti.translation[2]);
  tilted.translation[1] += b * std::tan(2 * a);
  EXPECT_THROW(tilted.validate(), Error);
  StereoCalibration reversed = kitti;
  for (double& t : reversed.translation) t = -t;
  try {
    reversed.validate();
    ADD_FAILURE() << "a reversed translation passed";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("swap them?"), std::string::npos) << e.what();
  }
}

TEST(CalibrationErrors, ValidateNamesTheSource) {
  StereoCalibration c;
  c.source = "rig.toml";
  try {
    c.validate();
    ADD_FAILURE() << "a default calibration has no focal length";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("rig.toml: ", 0), 0u) << e.what();
  }
  c.left =
      c.right = {CameraModel::kKannalaBrandt, 64, 48, 50, 50, 32, 24, {0.1, 0.0, 0.0, 0.0, 0.0}};
  c.translation = {-0.1, 0, 0};
  EXPECT_THROW(c.validate(), Error);  // five coefficients for a fisheye
  c.left.distortion.resize(4);
  c.right.distortion.resize(4);
  EXPECT_NO_THROW(c.validate());
  c.translation = {std::nan(""), 0, 0};
  EXPECT_THROW(c.validate(), Error);
  c.translation = {-0.1, 0, 0};
  c.is_rectified = true;  // rectified geometry not filled in
  EXPECT_THROW(c.validate(), Error);
}

}  // namespace
}  // namespace dco
