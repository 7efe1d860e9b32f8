// Entry point: arbitrary bytes as a DCO_RAW message, taken as far as an lcmlog:// replay takes
// one: the LCM decode, the two PNG images, the IMU rows and the recorded calibration. Each step
// refuses bad input with a message; images that decode have the size and eyes the message says.

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "dco/core/calibration.hpp"
#include "dco/core/error.hpp"
#include "dco/core/image.hpp"
#include "dco/drivers/raw_stereo.hpp"
#include "dco/ipc/lcm_messages.hpp"
#include "fuzz_target.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  dco::raw_stereo_t message;
  std::string problem;
  if (!dco::ipc::decode_message(data, size, message, problem)) {
    if (problem.empty()) std::abort();
    return 0;
  }
  dco::Image<std::uint8_t> left, right;
  try {
    dco::drivers::decode_raw_stereo(message, left, right);
    if (left.width() != message.width || left.height() != message.height ||
        right.width() != left.width() || right.height() != left.height() ||
        right.channels() != left.channels() || (left.channels() != 1 && left.channels() != 3))
      std::abort();
  } catch (const dco::Error& e) {
    if (e.what()[0] == '\0') std::abort();
  }
  std::vector<dco::drivers::ImuSample> imu;
  try {
    dco::drivers::decode_raw_imu(message, imu);
    if (imu.size() != message.imu_ns.size()) std::abort();
  } catch (const dco::Error& e) {
    if (e.what()[0] == '\0') std::abort();
  }
  try {
    dco::calibration_from_toml(message.calibration, "recorded calibration");
  } catch (const dco::Error& e) {
    if (e.what()[0] == '\0') std::abort();
  }
  return 0;
}
