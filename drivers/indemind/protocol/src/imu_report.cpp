#include "dco/indemind/imu_report.hpp"

#include "dco/indemind/byte_order.hpp"

namespace dco::indemind {
namespace {

constexpr double kAccelLsbPerG[4] = {16384, 8192, 4096, 2048};
constexpr double kGyroLsbPerDps[4] = {131, 65.5, 32.8, 16.4};

std::int16_t signed16(std::span<const std::uint8_t> b, std::size_t at) {
  return static_cast<std::int16_t>(read_be16(b, at));
}

int clamp_index(int i) {
  return i < 0 ? 0 : i > 3 ? 3 : i;
}

}  // namespace

double ImuRanges::accel_lsb_per_g() const {
  return kAccelLsbPerG[clamp_index(accel_index)];
}
double ImuRanges::gyro_lsb_per_dps() const {
  return kGyroLsbPerDps[clamp_index(gyro_index)];
}

std::optional<ImuReport> parse_imu_report(std::span<const std::uint8_t> b) {
  if (b.size() != kImuReportBytes) return std::nullopt;
  ImuReport r;
  r.frame_counter = read_be16(b, 4);
  r.ticks = read_be32(b, 6);
  for (int i = 0; i < 3; ++i) {
    r.accel_raw[i] = signed16(b, 11 + 2 * i);
    r.gyro_raw[i] = signed16(b, 19 + 2 * i);
  }
  r.temperature_raw = signed16(b, 17);
  return r;
}

std::array<std::uint8_t, kImuReportBytes> encode_imu_report(const ImuReport& r) {
  std::array<std::uint8_t, kImuReportBytes> b{};
  write_be16(b, 4, r.frame_counter);
  write_be32(b, 6, r.ticks);
  for (int i = 0; i < 3; ++i) {
    write_be16(b, 11 + 2 * i, static_cast<std::uint16_t>(r.accel_raw[i]));
    write_be16(b, 19 + 2 * i, static_cast<std::uint16_t>(r.gyro_raw[i]));
  }
  write_be16(b, 17, static_cast<std::uint16_t>(r.temperature_raw));
  return b;
}

ImuSample to_sample(const ImuReport& r, const ImuRanges& ranges) {
  ImuSample s;
  const double a = ranges.accel_lsb_per_g(), g = ranges.gyro_lsb_per_dps();
  for (int i = 0; i < 3; ++i) {
    s.accel_g[i] = static_cast<float>(r.accel_raw[i] / a);
    s.gyro_dps[i] = static_cast<float>(r.gyro_raw[i] / g);
  }
  // ICM-20602 datasheet: 326.8 LSB/°C around 25 °C.
  s.temperature_c = static_cast<float>(r.temperature_raw / 326.8 + 25.0);
  return s;
}

}  // namespace dco::indemind
