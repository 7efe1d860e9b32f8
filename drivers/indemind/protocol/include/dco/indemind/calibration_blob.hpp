#pragma once

// The calibration blob an INDEMIND module keeps in its SPI flash (design/indemind-protocol.md §5):
// a 140-byte header at kFlashHeaderAddress whose first u32 is the blob length, and the blob at
// kFlashBlobAddress. The blob is the vendor SDK's POD memory image (little-endian, natural
// alignment); its length gives the version. Matrices are row-major.
//
// Offsets: left camera 0, right camera 440, IMU 880, module info 1312, SLAM parameters 1568
// (ignored; encoded as zeros), v1: three int32 at 1608, v2: int32 module type at 1624.

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace dco::indemind {

inline constexpr std::size_t kCalibrationBlobSizeV0 = 1608;
inline constexpr std::size_t kCalibrationBlobSizeV1 = 1624;
inline constexpr std::size_t kCalibrationBlobSizeV2 = 1632;

inline constexpr std::uint32_t kFlashHeaderAddress = 0x3F0000;
inline constexpr std::size_t kFlashHeaderSize = 140;
inline constexpr std::uint32_t kFlashBlobAddress = 0x200000;

// One camera, as calibrated at the stored resolution (1280x800 on the known modules).
struct CameraParameter {
  std::array<double, 16> t_sc{};  // camera -> IMU, 4x4
  std::int32_t width = 0;
  std::int32_t height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;  // duplicates of k[0], k[4], k[2], k[5]
  std::array<double, 9> r{};              // rectifying rotation
  std::array<double, 12> p{};             // rectified projection 3x4; p[3] = -f * baseline
  std::array<double, 9> k{};              // camera matrix
  std::array<double, 4> d{};              // Kannala-Brandt (equidistant) k1..k4, not radtan

  bool operator==(const CameraParameter&) const = default;
};

struct ImuParameter {
  double a_max = 0, g_max = 0;
  double sigma_g_c = 0, sigma_a_c = 0, sigma_bg = 0, sigma_ba = 0, sigma_gw_c = 0, sigma_aw_c = 0;
  double tau = 0, g = 0;
  std::array<double, 4> a0{};
  std::array<double, 16> t_bs{};  // body -> sensor, 4x4
  std::array<double, 12> acc{};   // rows [b_i, M_i1, M_i2, M_i3]: a = M * (raw - b)
  std::array<double, 12> gyr{};   // same layout for the gyroscope

  bool operator==(const ImuParameter&) const = default;
};

// The blob's char[32] strings, made safe to print: cut at the first NUL (or all 32 bytes when
// unterminated), trailing blanks removed, any other non-printable byte replaced by '?'.
struct ModuleInfo {
  std::string id, designer, firmware_version, hardware_version, lens, imu, viewing_angle, baseline;

  bool operator==(const ModuleInfo&) const = default;
};

enum class ModuleType : std::int32_t { kNormal = 0, kAr = 1, kMr = 2 };

// AR and MR modules send the left camera in the right half of each sensor row (§3.1): the driver
// swaps the halves, and to_stereo_calibration swaps the blob's cameras to match.
constexpr bool swaps_halves(ModuleType t) {
  return t == ModuleType::kAr || t == ModuleType::kMr;
}

struct ModuleCalibration {
  int version = 0;  // 0, 1 or 2, from the blob length
  // Named by sensor half: `left` is the camera whose pixels come first in each row of the raw
  // frame (for AR/MR modules that is the physically right camera).
  CameraParameter left, right;
  ImuParameter imu;
  ModuleInfo info;
  std::optional<int> img_frequency, img_resolution, imu_frequency;  // v1 and later
  ModuleType module_type = ModuleType::kNormal;                     // v2; kNormal before

  bool operator==(const ModuleCalibration&) const = default;
};

// Blob length of a version (0, 1, 2); throws dco::Error for any other.
std::size_t calibration_blob_size(int version);

// The blob length announced by the flash header (its first u32, little-endian). Throws dco::Error
// when the header is shorter than 4 bytes, the flash is erased, or the length is not a known one.
std::size_t parse_flash_header(std::span<const std::uint8_t> header);

// Decodes a blob of 1608, 1624 or 1632 bytes. Throws dco::Error naming the field for: another
// size, a non-finite camera or IMU number, a width or height outside 1..8192, fx or fy <= 0, a
// module type other than 0..2. Geometry is judged by to_stereo_calibration, not here.
ModuleCalibration parse_calibration_blob(std::span<const std::uint8_t> blob);

// The inverse of parse_calibration_blob: parse(encode(m)) == m. Numbers are written unchecked (so
// tests can build bad blobs); throws dco::Error when `m` has no exact encoding: a version other
// than 0..2, a string longer than 32 bytes, v1 fields missing (v1+) or present (v0), a module
// type other than kNormal before v2.
std::vector<std::uint8_t> encode_calibration_blob(const ModuleCalibration& m);

}  // namespace dco::indemind
