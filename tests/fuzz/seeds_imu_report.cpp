#include "dco/indemind/imu_report.hpp"
#include "fuzz_target.hpp"

namespace dco::fuzz {

std::vector<std::vector<std::uint8_t>> seeds() {
  using namespace dco::indemind;
  ImuReport r;
  r.frame_counter = 65535;
  r.ticks = 1'600'000;
  r.accel_raw = {-32768, 32767, 2048};
  r.gyro_raw = {164, -164, 0};
  const auto bytes = encode_imu_report(r);
  return {std::vector<std::uint8_t>(bytes.begin(), bytes.end()),
          std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + 20)};
}

}  // namespace dco::fuzz
