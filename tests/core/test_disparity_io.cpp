#include "dco/core/disparity_io.hpp"

#include <bit>
#include <cmath>
#include <cstring>
#include <iterator>
#include <limits>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "dco/core/error.hpp"
#include "test_support.hpp"

namespace dco {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

Image<float> ramp(int w, int h, int c) {
  Image<float> img(w, h, c);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < c; ++k) img.at(x, y, k) = 0.25f * x - 3.5f * y + 100.0f * k;
  return img;
}

void expect_equal(const Image<float>& a, const Image<float>& b) {
  ASSERT_EQ(a.width(), b.width());
  ASSERT_EQ(a.height(), b.height());
  ASSERT_EQ(a.channels(), b.channels());
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x)
      for (int c = 0; c < a.channels(); ++c)
        ASSERT_EQ(std::memcmp(&a.at(x, y, c), &b.at(x, y, c), sizeof(float)), 0)
            << "at " << x << "," << y << "," << c;
}

TEST(Pfm, RoundTripOneChannelKeepsInfinity) {
  test::TempDir dir;
  Image<float> img = ramp(7, 5, 1);
  img.at(2, 1) = kInf;
  img.at(6, 4) = -kInf;
  write_pfm(dir / "a.pfm", img.cview());
  const Image<float> back = read_pfm(dir / "a.pfm");
  expect_equal(img, back);
  EXPECT_TRUE(std::isinf(back.at(2, 1)) && back.at(2, 1) > 0);
}

TEST(Pfm, RoundTripThreeChannels) {
  test::TempDir dir;
  const Image<float> img = ramp(4, 3, 3);
  write_pfm(dir / "c.pfm", img.cview());
  EXPECT_EQ(test::read_file(dir / "c.pfm").substr(0, 3), "PF\n");
  expect_equal(img, read_pfm(dir / "c.pfm"));
}

TEST(Pfm, RowsAreStoredBottomToTop) {
  test::TempDir dir;
  Image<float> img(2, 2);
  img.at(0, 0) = 1;  // top row
  img.at(1, 0) = 2;
  img.at(0, 1) = 3;  // bottom row
  img.at(1, 1) = 4;
  write_pfm(dir / "o.pfm", img.cview());
  const std::string bytes = test::read_file(dir / "o.pfm");
  ASSERT_GE(bytes.size(), 16u);
  float first = 0;
  std::memcpy(&first, bytes.data() + bytes.size() - 16, 4);
  EXPECT_EQ(first, 3.0f);  // the file starts with the bottom row
}

TEST(Pfm, ReadsBigEndian) {
  test::TempDir dir;
  std::string bytes = "Pf\n2 2\n1.0\n";               // positive scale: big-endian
  const float values[4] = {3.0f, 4.0f, 1.0f, -2.5f};  // bottom row first
  for (float v : values) {
    std::uint32_t bits;
    std::memcpy(&bits, &v, 4);
    for (int shift = 24; shift >= 0; shift -= 8) bytes.push_back(static_cast<char>(bits >> shift));
  }
  test::write_file(dir / "be.pfm", bytes);
  const Image<float> img = read_pfm(dir / "be.pfm");
  ASSERT_EQ(img.width(), 2);
  ASSERT_EQ(img.height(), 2);
  EXPECT_EQ(img.at(0, 0), 1.0f);
  EXPECT_EQ(img.at(1, 0), -2.5f);
  EXPECT_EQ(img.at(0, 1), 3.0f);
  EXPECT_EQ(img.at(1, 1), 4.0f);
}

TEST(Pfm, BadFilesThrowNamingTheFile) {
  test::TempDir dir;
  const auto expect_error = [&](const std::string& name, const std::string& bytes) {
    test::write_file(dir / name, bytes);
    try {
      read_pfm(dir / name);
      ADD_FAILURE() << name << " was accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  };
  expect_error("truncated.pfm", "Pf\n4 4\n-1.0\n" + std::string(10, '\0'));
  expect_error("magic.pfm", "P6\n4 4\n255\n" + std::string(48, '\0'));
  expect_error("header.pfm", "Pf\nabc 4\n-1.0\n" + std::string(64, '\0'));
  expect_error("scale.pfm", "Pf\n2 2\n0\n" + std::string(16, '\0'));
  expect_error("size.pfm", "Pf\n-2 2\n-1\n" + std::string(16, '\0'));
  expect_error("trailing.pfm", "Pf\n2abc 2\n-1.0\n" + std::string(16, '\0'));
  // 64k x 64k x 3 floats announced in 20 bytes: refused before any allocation.
  expect_error("huge.pfm", "PF\n65536 65536\n-1.0\n");
  expect_error("empty.pfm", "");
  EXPECT_THROW(read_pfm(dir / "missing.pfm"), Error);
}

// A header written with CRLF line ends: the LF is the header's, not the data's first byte.
TEST(Pfm, ReadsAHeaderEndedByCrLf) {
  test::TempDir dir;
  const Image<float> img = ramp(4, 2, 1);
  write_pfm(dir / "lf.pfm", img.cview());
  std::string bytes = test::read_file(dir / "lf.pfm");
  std::string crlf;
  int newlines = 0;
  for (const char c : bytes) {
    if (c == '\n' && newlines < 3) {
      crlf += "\r\n";
      ++newlines;
    } else {
      crlf += c;
    }
  }
  test::write_file(dir / "crlf.pfm", crlf);
  expect_equal(read_pfm(dir / "crlf.pfm"), img);
}

// Whitespace a writer put after the scale belongs to the header; a byte past the data means the
// data cannot be placed, and is refused rather than read shifted.
TEST(Pfm, HeaderPaddingIsSkippedAndExtraBytesAreRefused) {
  test::TempDir dir;
  const Image<float> img = ramp(3, 2, 1);
  write_pfm(dir / "plain.pfm", img.cview());
  const std::string bytes = test::read_file(dir / "plain.pfm");
  const std::size_t header = bytes.size() - 3 * 2 * sizeof(float);
  ASSERT_EQ(bytes[header - 1], '\n');
  const std::string head = bytes.substr(0, header - 1), data = bytes.substr(header);

  test::write_file(dir / "space.pfm", head + " \n" + data);
  expect_equal(read_pfm(dir / "space.pfm"), img);
  test::write_file(dir / "crlf_pad.pfm", head + "\r\n " + data);
  expect_equal(read_pfm(dir / "crlf_pad.pfm"), img);

  const auto refused = [&](const std::string& name, const std::string& file) {
    test::write_file(dir / name, file);
    try {
      read_pfm(dir / name);
      ADD_FAILURE() << name << " was accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(name + "': PFM holds"), std::string::npos) << e.what();
    }
  };
  refused("tail.pfm", bytes + "x");
  refused("tail_newline.pfm", head + "\n" + data + std::string(4, '\0'));
  refused("padding.pfm", head + std::string(12, ' ') + data);
}

TEST(Pfm, ReadsMiddleburyGroundTruth) {
  const auto dir = test::data_dir() / "middlebury2014" / "Motorcycle";
  const Image<float> gt = read_pfm(dir / "disp0GT.pfm");
  ASSERT_EQ(gt.width(), 741);
  ASSERT_EQ(gt.height(), 497);
  ASSERT_EQ(gt.channels(), 1);
  long unknown = 0;
  float lo = kInf, hi = -kInf;
  for (int y = 0; y < gt.height(); ++y)
    for (int x = 0; x < gt.width(); ++x) {
      const float d = gt.at(x, y);
      if (std::isinf(d)) {
        EXPECT_GT(d, 0);
        ++unknown;
      } else {
        lo = std::min(lo, d);
        hi = std::max(hi, d);
      }
    }
  EXPECT_GT(unknown, 0);
  EXPECT_LT(unknown, gt.width() * gt.height() / 10);
  EXPECT_GT(lo, 9.0f);
  EXPECT_LT(lo, 10.0f);
  EXPECT_GT(hi, 62.0f);
  EXPECT_LT(hi, 64.0f);

  // Orientation: mask0nocc.png (stored top-down) is 0 exactly where the GT is unknown, so a
  // flipped read would disagree almost everywhere along the unknown regions.
  const cv::Mat mask = cv::imread((dir / "mask0nocc.png").string(), cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(mask.cols, 741);
  long agree = 0, disagree = 0;
  for (int y = 0; y < gt.height(); ++y)
    for (int x = 0; x < gt.width(); ++x)
      ((mask.at<std::uint8_t>(y, x) == 0) == std::isinf(gt.at(x, y)) ? agree : disagree)++;
  EXPECT_EQ(disagree, 0) << "agree " << agree;
}

TEST(DisparityPng16, RoundTripQuantisesToSixteenthsOfAPixel) {
  test::TempDir dir;
  Image<float> d(5, 2);
  const float values[10] = {0.0f,  -1.0f,  kInf,    std::nanf(""), 1.0f / 256,
                            12.3f, 100.5f, 255.99f, 300.0f,        0.001f};
  for (int i = 0; i < 10; ++i) d.at(i % 5, i / 5) = values[i];
  write_disparity_png16(dir / "d.png", d.cview());
  const Image<float> back = read_disparity_png16(dir / "d.png");
  ASSERT_EQ(back.width(), 5);
  ASSERT_EQ(back.height(), 2);
  EXPECT_TRUE(std::isinf(back.at(0, 0)));  // 0 = unknown
  EXPECT_TRUE(std::isinf(back.at(1, 0)));  // negative
  EXPECT_TRUE(std::isinf(back.at(2, 0)));
  EXPECT_TRUE(std::isinf(back.at(3, 0)));  // NaN
  EXPECT_EQ(back.at(4, 0), 1.0f / 256);
  EXPECT_NEAR(back.at(0, 1), 12.3f, 0.5f / 256);
  EXPECT_EQ(back.at(1, 1), 100.5f);
  EXPECT_NEAR(back.at(2, 1), 255.99f, 0.5f / 256);
  EXPECT_EQ(back.at(3, 1), 65535.0f / 256);  // clamped
  EXPECT_EQ(back.at(4, 1), 1.0f / 256);      // tiny but positive stays known
}

TEST(DepthPng16, RoundTripInMillimetres) {
  test::TempDir dir;
  Image<float> z(4, 1);
  z.at(0, 0) = 1.2346f;
  z.at(1, 0) = 0.0f;
  z.at(2, 0) = 70.0f;
  z.at(3, 0) = kInf;
  write_depth_png16(dir / "z.png", z.cview());
  const Image<float> back = read_depth_png16(dir / "z.png");
  EXPECT_NEAR(back.at(0, 0), 1.235f, 1e-6f);
  EXPECT_TRUE(std::isinf(back.at(1, 0)));
  EXPECT_NEAR(back.at(2, 0), 65.535f, 1e-6f);
  EXPECT_TRUE(std::isinf(back.at(3, 0)));
  // Far beyond the range: the farthest value, not a wrapped round-off to the nearest one.
  Image<float> far(2, 1);
  far.at(0, 0) = 1e16f;
  far.at(1, 0) = 3e38f;
  write_depth_png16(dir / "far.png", far.cview());
  const Image<float> far_back = read_depth_png16(dir / "far.png");
  EXPECT_NEAR(far_back.at(0, 0), 65.535f, 1e-6f);
  EXPECT_NEAR(far_back.at(1, 0), 65.535f, 1e-6f);
}

TEST(DisparityPng16, RefusesEightBitAndMissingFiles) {
  test::TempDir dir;
  cv::Mat eight(4, 4, CV_8UC1, cv::Scalar(7));
  ASSERT_TRUE(cv::imwrite((dir / "eight.png").string(), eight));
  EXPECT_THROW(read_disparity_png16(dir / "eight.png"), Error);
  EXPECT_THROW(read_depth_png16(dir / "nope.png"), Error);
  Image<float> three(2, 2, 3);
  EXPECT_THROW(write_disparity_png16(dir / "x.png", three.cview()), Error);
}

// A 16-bit colour PNG (KITTI's optical flow is one) is not a map whose channels may be mixed.
TEST(DisparityPng16, RefusesColour) {
  test::TempDir dir;
  cv::Mat colour(2, 2, CV_16UC3, cv::Scalar(160, 640, 1));
  ASSERT_TRUE(cv::imwrite((dir / "flow.png").string(), colour));
  for (const auto read : {&read_disparity_png16, &read_depth_png16}) try {
      read(dir / "flow.png");
      ADD_FAILURE() << "a colour PNG was read as a map";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("has 3 channels"), std::string::npos) << e.what();
    }
}

// OpenCV decodes by content and throws from some decoders (a PFM of height 0 under a .png name);
// a PNG's claimed size is checked before anything is inflated.
TEST(DisparityPng16, CorruptAndHugeFilesAreClearErrors) {
  test::TempDir dir;
  test::write_file(dir / "zero_height.png", std::string("Pf\n7 0\n-1\n") + std::string(64, '\0'));
  try {
    read_disparity_png16(dir / "zero_height.png");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot decode disparity PNG"), std::string::npos)
        << e.what();
  }
  // 20000 x 20000 at 16 bits (800 MB) in a 33-byte file.
  const unsigned char header[] = {0x89, 'P',  'N', 'G', '\r', '\n', 0x1a, '\n', 0,    0, 0,
                                  13,   'I',  'H', 'D', 'R',  0,    0,    0x4e, 0x20, 0, 0,
                                  0x4e, 0x20, 16,  0,   0,    0,    0,    0,    0,    0, 0};
  test::write_file(dir / "huge.png", std::string(std::begin(header), std::end(header)));
  try {
    read_depth_png16(dir / "huge.png");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("is a 20000x20000 PNG (sides at most 16384)"),
              std::string::npos)
        << e.what();
  }
}

TEST(DisparityPng16, ReadsKittiGroundTruth) {
  const auto path = test::data_dir() / "kitti2015" / "000046" / "disp_occ_0";
  std::filesystem::path file;
  for (const auto& entry : std::filesystem::directory_iterator(path))
    if (entry.path().extension() == ".png") file = entry.path();
  ASSERT_FALSE(file.empty());
  const Image<float> d = read_disparity_png16(file);
  EXPECT_EQ(d.width(), 1242);
  EXPECT_EQ(d.height(), 375);
  long known = 0, unknown = 0;
  for (int y = 0; y < d.height(); ++y)
    for (int x = 0; x < d.width(); ++x) {
      const float v = d.at(x, y);
      if (std::isinf(v)) {
        ++unknown;
      } else {
        ++known;
        ASSERT_GT(v, 0.0f);
        ASSERT_LT(v, 256.0f);
      }
    }
  EXPECT_GT(known, 0);
  EXPECT_GT(unknown, 0);  // sparse ground truth
}

}  // namespace
}  // namespace dco
