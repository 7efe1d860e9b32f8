#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

namespace dco::indemind {

// One 32-byte report from interrupt endpoint 0x89 (protocol notes §4.1), big-endian fields.
inline constexpr std::size_t kImuReportBytes = 32;
// The sub-frame tick counter runs at 160 MHz.
inline constexpr double kImuTicksPerSecond = 160e6;
// The ICM-20602 samples at 1 kHz divided by SMPLRT_DIV + 1, an 8-bit register: its rates divide
// 1000 and are at least 1000 / 256 Hz.
inline constexpr int kMinImuHz = 4;

struct ImuReport {
  std::uint16_t frame_counter = 0;  // the camera frame counter when the sample was taken
  std::uint32_t ticks = 0;          // since that frame started
  std::array<std::int16_t, 3> accel_raw{};
  std::int16_t temperature_raw = 0;
  std::array<std::int16_t, 3> gyro_raw{};
};

// ICM-20602 full-scale ranges by register index 0..3: ±2/4/8/16 g and ±250/500/1000/2000 °/s.
struct ImuRanges {
  int accel_index = 3;
  int gyro_index = 3;
  double accel_lsb_per_g() const;
  double gyro_lsb_per_dps() const;
};

// A sample in physical units: g and degrees per second, as the module's own software reports.
struct ImuSample {
  std::int64_t device_ns = 0;  // device time line (frame counter × nominal period + ticks)
  std::int64_t host_ns = 0;    // CLOCK_MONOTONIC, through the clock map
  std::array<float, 3> accel_g{};
  std::array<float, 3> gyro_dps{};
  float temperature_c = 0;
};

// nullopt when the report is not exactly 32 bytes.
std::optional<ImuReport> parse_imu_report(std::span<const std::uint8_t> report);
std::array<std::uint8_t, kImuReportBytes> encode_imu_report(const ImuReport& report);

// Scales a report; device_ns and host_ns are left for the caller.
ImuSample to_sample(const ImuReport& report, const ImuRanges& ranges);

}  // namespace dco::indemind
