#include "dco/indemind/calibration_blob.hpp"

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "support/error_of.hpp"

namespace dco::indemind {
namespace {

using Bytes = std::vector<std::uint8_t>;

void put_u32(Bytes& b, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

void put_f64(Bytes& b, std::size_t at, double v) {
  const auto bits = std::bit_cast<std::uint64_t>(v);
  for (int i = 0; i < 8; ++i) b[at + i] = static_cast<std::uint8_t>(bits >> (8 * i));
}

void put_text(Bytes& b, std::size_t at, const std::string& s) {
  std::memcpy(b.data() + at, s.data(), s.size());
}

// A 1280x800 module with a 0.12 m baseline, f ~ 697 px and small KB4 coefficients; the
// rectification is a plausible one written by hand (module_calibration's tests use OpenCV's).
// Camera axes are turned 180 degrees about z against the IMU's; `imu_x` is the camera's x there.
CameraParameter camera(double fx, double cx, double tx, double imu_x) {
  CameraParameter c;
  c.t_sc = {-1, 0, 0, imu_x, 0, -1, 0, 0.002, 0, 0, 1, -0.001, 0, 0, 0, 1};
  c.width = 1280;
  c.height = 800;
  c.fx = fx;
  c.fy = fx - 0.4;
  c.cx = cx;
  c.cy = 401.25;
  c.r = {0.99999, 0.0031, -0.0012, -0.0031, 0.99999, 0.0008, 0.0012, -0.0008, 1.0};
  c.p = {690.5, 0, 640.0, tx, 0, 690.5, 400.0, 0, 0, 0, 1, 0};
  c.k = {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1};
  c.d = {-0.0123, 0.0041, -0.00162, 0.00021};
  return c;
}

ModuleCalibration module(int version) {
  ModuleCalibration m;
  m.version = version;
  m.left = camera(697.3, 641.7, 0, 0.06);
  m.right = camera(698.9, 637.2, -690.5 * 0.12, -0.06);
  ImuParameter& imu = m.imu;
  imu.a_max = 16;
  imu.g_max = 2000;
  imu.sigma_g_c = 0.0021;
  imu.sigma_a_c = 0.087;
  imu.sigma_bg = imu.sigma_ba = 4e-5;
  imu.sigma_gw_c = 4.1e-5;
  imu.sigma_aw_c = 3.9e-5;
  imu.tau = 3600;
  imu.g = 9.8019967;
  imu.a0 = {0.01, 0.02, 0.03, 0.04};
  imu.t_bs = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  imu.acc = {0.011, 1.001, 0.002, -0.001, -0.02, 0.001, 0.998, 0.003, 0.005, -0.002, 0.001, 1.002};
  imu.gyr = {0.1, 1, 0, 0, -0.2, 0, 1, 0, 0.3, 0, 0, 1};
  m.info = {"M1", "INDEMIND", "1.0", "H2", "2.1mm", "ICM-20602", "130", "120mm"};
  if (version >= 1) {
    m.img_frequency = 50;
    m.img_resolution = 1280;
    m.imu_frequency = 1000;
  }
  if (version >= 2) m.module_type = ModuleType::kMr;
  return m;
}

using dco::testing::error_of;

TEST(CalibrationBlob, RoundTripsEveryVersion) {
  const std::size_t sizes[] = {kCalibrationBlobSizeV0, kCalibrationBlobSizeV1,
                               kCalibrationBlobSizeV2};
  for (int version = 0; version <= 2; ++version) {
    SCOPED_TRACE(version);
    const ModuleCalibration m = module(version);
    const Bytes blob = encode_calibration_blob(m);
    ASSERT_EQ(blob.size(), sizes[version]);
    EXPECT_EQ(calibration_blob_size(version), sizes[version]);
    const ModuleCalibration back = parse_calibration_blob(blob);
    EXPECT_EQ(back.version, version);
    EXPECT_TRUE(back == m);
    EXPECT_EQ(encode_calibration_blob(back), blob);
  }
  EXPECT_EQ(parse_calibration_blob(encode_calibration_blob(module(1))).module_type,
            ModuleType::kNormal);
  EXPECT_FALSE(parse_calibration_blob(encode_calibration_blob(module(0))).img_frequency);
}

// Values placed by hand at the offsets of design/indemind-protocol.md §5.2, little-endian.
TEST(CalibrationBlob, ReadsTheDocumentedOffsets) {
  Bytes b(kCalibrationBlobSizeV2, 0);
  for (std::size_t cam : {0u, 440u}) {
    put_u32(b, cam + 128, 1280);
    put_u32(b, cam + 132, 800);
    put_f64(b, cam + 136, 697.5 + static_cast<double>(cam));  // fx
    put_f64(b, cam + 144, 696.5);                             // fy
  }
  put_f64(b, 0, 0.25);                 // left T_SC[0]
  put_f64(b, 152, 640.5);              // left cx
  put_f64(b, 160, 399.5);              // left cy
  put_f64(b, 168, 0.75);               // left R[0]
  put_f64(b, 240 + 3 * 8, -83.25);     // left P[3]
  put_f64(b, 336 + 8 * 8, 1.0);        // left K[8]
  put_f64(b, 408 + 3 * 8, 2e-4);       // left D[3]
  put_f64(b, 440 + 240 + 3 * 8, -84);  // right P[3]
  put_f64(b, 880, 16);                 // a_max
  put_f64(b, 880 + 9 * 8, 9.80);       // g
  put_f64(b, 960 + 3 * 8, 0.5);        // a0[3]
  put_f64(b, 992 + 15 * 8, 1);         // T_BS[15]
  put_f64(b, 1120, 0.01);              // Acc[0]
  put_f64(b, 1216 + 11 * 8, 1.5);      // Gyr[11]
  put_text(b, 1312, "ID-7");
  put_text(b, 1312 + 64, "fw 2.3");
  put_text(b, 1312 + 7 * 32, "120mm");
  put_u32(b, 1608, 100);
  put_u32(b, 1612, 640);
  put_u32(b, 1616, 500);
  put_u32(b, 1624, 1);

  const ModuleCalibration m = parse_calibration_blob(b);
  EXPECT_EQ(m.version, 2);
  EXPECT_EQ(m.left.t_sc[0], 0.25);
  EXPECT_EQ(m.left.width, 1280);
  EXPECT_EQ(m.left.height, 800);
  EXPECT_EQ(m.left.fx, 697.5);
  EXPECT_EQ(m.left.fy, 696.5);
  EXPECT_EQ(m.left.cx, 640.5);
  EXPECT_EQ(m.left.cy, 399.5);
  EXPECT_EQ(m.left.r[0], 0.75);
  EXPECT_EQ(m.left.p[3], -83.25);
  EXPECT_EQ(m.left.k[8], 1.0);
  EXPECT_EQ(m.left.d[3], 2e-4);
  EXPECT_EQ(m.right.fx, 697.5 + 440);
  EXPECT_EQ(m.right.p[3], -84);
  EXPECT_EQ(m.imu.a_max, 16);
  EXPECT_EQ(m.imu.g, 9.80);
  EXPECT_EQ(m.imu.a0[3], 0.5);
  EXPECT_EQ(m.imu.t_bs[15], 1);
  EXPECT_EQ(m.imu.acc[0], 0.01);
  EXPECT_EQ(m.imu.gyr[11], 1.5);
  EXPECT_EQ(m.info.id, "ID-7");
  EXPECT_EQ(m.info.firmware_version, "fw 2.3");
  EXPECT_EQ(m.info.baseline, "120mm");
  EXPECT_EQ(m.info.designer, "");
  EXPECT_EQ(m.img_frequency, 100);
  EXPECT_EQ(m.img_resolution, 640);
  EXPECT_EQ(m.imu_frequency, 500);
  EXPECT_EQ(m.module_type, ModuleType::kAr);

  // The writer puts every field back where it came from (and zeros elsewhere).
  EXPECT_EQ(encode_calibration_blob(m), b);

  // Misaligned input decodes the same.
  Bytes shifted(b.size() + 3);
  std::memcpy(shifted.data() + 3, b.data(), b.size());
  EXPECT_TRUE(parse_calibration_blob(std::span<const std::uint8_t>(shifted).subspan(3)) == m);
}

TEST(CalibrationBlob, EncodesZerosOutsideTheFields) {
  const Bytes b = encode_calibration_blob(module(2));
  for (std::size_t i = 1568; i < 1608; ++i) ASSERT_EQ(b[i], 0) << i;  // SLAM parameters
  for (std::size_t i = 1620; i < 1624; ++i) ASSERT_EQ(b[i], 0) << i;  // padding
  for (std::size_t i = 1628; i < 1632; ++i) ASSERT_EQ(b[i], 0) << i;
  EXPECT_EQ(b[1312 + 2], 0);  // "M1" is NUL-terminated
}

TEST(CalibrationBlob, RejectsUnknownSizes) {
  const Bytes full = encode_calibration_blob(module(2));
  for (std::size_t size : {0u, 4u, 140u, 1607u, 1609u, 1623u, 1625u, 1631u}) {
    const std::string msg =
        error_of([&] { parse_calibration_blob(std::span<const std::uint8_t>(full).first(size)); });
    EXPECT_NE(msg.find(std::to_string(size) + " bytes"), std::string::npos) << msg;
    EXPECT_NE(msg.find("1608"), std::string::npos) << msg;
  }
  Bytes longer = full;
  longer.resize(1640);
  EXPECT_THROW(parse_calibration_blob(longer), Error);
}

TEST(CalibrationBlob, RejectsNonFiniteNumbersNamingTheField) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    std::size_t offset;
    double value;
    const char* field;
  };
  const Case cases[] = {
      {0, nan, "left camera T_SC[0]"},
      {136, inf, "left camera fx"},
      {160, -inf, "left camera cy"},
      {440 + 240 + 24, nan, "right camera P[3]"},
      {440 + 408 + 8, nan, "right camera D[1]"},
      {880 + 72, inf, "IMU g"},
      {992 + 5 * 8, nan, "IMU T_BS[5]"},
      {1216 + 11 * 8, nan, "IMU Gyr[11]"},
  };
  for (const Case& c : cases) {
    Bytes b = encode_calibration_blob(module(2));
    put_f64(b, c.offset, c.value);
    const std::string msg = error_of([&] { parse_calibration_blob(b); });
    EXPECT_NE(msg.find(std::string(c.field) + " is not finite"), std::string::npos) << msg;
  }
}

TEST(CalibrationBlob, RejectsBadImageSizesAndFocalLengths) {
  const auto with = [](auto edit) {
    ModuleCalibration m = module(1);
    edit(m);
    return encode_calibration_blob(m);
  };
  EXPECT_NE(error_of([&] {
              parse_calibration_blob(with([](auto& m) { m.left.width = 0; }));
            }).find("left camera width 0"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              parse_calibration_blob(with([](auto& m) { m.right.height = -800; }));
            }).find("right camera height -800"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              parse_calibration_blob(with([](auto& m) { m.left.width = 8193; }));
            }).find("8193"),
            std::string::npos);
  EXPECT_NO_THROW(parse_calibration_blob(with([](auto& m) { m.left.width = 8192; })));
  EXPECT_NE(error_of([&] {
              parse_calibration_blob(with([](auto& m) { m.left.fx = 0; }));
            }).find("left camera focal length"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              parse_calibration_blob(with([](auto& m) { m.right.fy = -1; }));
            }).find("right camera focal length"),
            std::string::npos);
}

TEST(CalibrationBlob, RejectsUnknownModuleTypes) {
  for (std::uint32_t type : {3u, 0xFFFFFFFFu, 0x01000000u}) {
    Bytes b = encode_calibration_blob(module(2));
    put_u32(b, 1624, type);
    const std::string msg = error_of([&] { parse_calibration_blob(b); });
    EXPECT_NE(msg.find("module type " + std::to_string(static_cast<std::int32_t>(type))),
              std::string::npos)
        << msg;
  }
  for (std::uint32_t type : {0u, 1u, 2u}) {
    Bytes b = encode_calibration_blob(module(2));
    put_u32(b, 1624, type);
    EXPECT_EQ(static_cast<std::uint32_t>(parse_calibration_blob(b).module_type), type);
  }
}

TEST(CalibrationBlob, ModuleInfoStringsArePrintable) {
  Bytes b = encode_calibration_blob(module(0));
  const std::string unterminated(32, 'X');
  put_text(b, 1312, unterminated);                   // id fills its 32 bytes
  put_text(b, 1312 + 32, std::string("ab\0cd", 5));  // designer: stop at NUL
  put_text(b, 1312 + 64,
           "v1\x01\xff\x7f"
           "2   ");                              // firmware: garbage, blanks
  put_text(b, 1312 + 96, "  H2 \t\r\n");         // hardware: leading blanks kept
  std::memset(b.data() + 1312 + 128, 0xFF, 32);  // lens: erased flash
  const ModuleInfo info = parse_calibration_blob(b).info;
  EXPECT_EQ(info.id, unterminated);
  EXPECT_EQ(info.designer, "ab");
  EXPECT_EQ(info.firmware_version, "v1???2");
  EXPECT_EQ(info.hardware_version, "  H2");
  EXPECT_EQ(info.lens, std::string(32, '?'));
  EXPECT_EQ(info.imu, "ICM-20602");
}

TEST(CalibrationBlob, EncodeRefusesWhatItCannotWriteExactly) {
  ModuleCalibration m = module(2);
  m.version = 3;
  EXPECT_NE(error_of([&] { encode_calibration_blob(m); }).find("version 3"), std::string::npos);
  m = module(2);
  m.imu_frequency.reset();
  EXPECT_THROW(encode_calibration_blob(m), Error);
  m = module(0);
  m.img_resolution = 640;
  EXPECT_THROW(encode_calibration_blob(m), Error);
  m = module(1);
  m.module_type = ModuleType::kAr;
  EXPECT_THROW(encode_calibration_blob(m), Error);
  m = module(2);
  m.info.lens = std::string(33, 'L');
  EXPECT_NE(error_of([&] { encode_calibration_blob(m); }).find("lens"), std::string::npos);
  m.info.lens = std::string(32, 'L');
  EXPECT_NO_THROW(encode_calibration_blob(m));
  m.info.imu = "a\nb";
  EXPECT_THROW(encode_calibration_blob(m), Error);
  m.info.imu = "trailing ";
  EXPECT_THROW(encode_calibration_blob(m), Error);
  EXPECT_THROW(calibration_blob_size(-1), Error);
}

TEST(FlashHeader, GivesTheBlobLength) {
  Bytes h(kFlashHeaderSize, 0xAB);
  for (std::uint32_t len : {1608u, 1624u, 1632u}) {
    put_u32(h, 0, len);
    EXPECT_EQ(parse_flash_header(h), len);
  }
  EXPECT_EQ(parse_flash_header(Bytes{0x60, 0x06, 0x00, 0x00}), 0x660u);  // little-endian 1632
  EXPECT_EQ(kFlashHeaderAddress, 0x3F0000u);
  EXPECT_EQ(kFlashBlobAddress, 0x200000u);
}

TEST(FlashHeader, RejectsErasedShortAndUnknown) {
  const Bytes erased(kFlashHeaderSize, 0xFF);
  EXPECT_NE(error_of([&] { parse_flash_header(erased); }).find("no calibration in flash (erased"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              parse_flash_header(Bytes{0x48, 0x06, 0});
            }).find("3 bytes"),
            std::string::npos);
  EXPECT_THROW(parse_flash_header(Bytes{}), Error);
  Bytes h(kFlashHeaderSize, 0);
  put_u32(h, 0, 1000);
  const std::string msg = error_of([&] { parse_flash_header(h); });
  EXPECT_NE(msg.find("1000"), std::string::npos) << msg;
  EXPECT_NE(msg.find("1608"), std::string::npos) << msg;
  EXPECT_NE(msg.find("1632"), std::string::npos) << msg;
  EXPECT_THROW(parse_flash_header(Bytes{0x00, 0x00, 0x06, 0x60}), Error);  // big-endian 1632
  EXPECT_THROW(parse_flash_header(Bytes(4, 0)), Error);
}

}  // namespace
}  // namespace dco::indemind
