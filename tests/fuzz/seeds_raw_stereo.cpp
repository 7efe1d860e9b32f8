// Seeds of the DCO_RAW target: small grey and colour pairs encoded as dcod records them, with a
// rectified calibration and a few IMU samples.

#include <cstdint>
#include <string>
#include <vector>

#include "dco/core/image.hpp"
#include "dco/drivers/frame_source.hpp"
#include "dco/drivers/raw_stereo.hpp"
#include "fuzz_target.hpp"

namespace dco::fuzz {
namespace {

constexpr const char* kCalibration =
    "[rectified]\nwidth = 32\nheight = 24\nf = 40.0\ncx_left = 15.5\ncx_right = 15.5\n"
    "cy = 11.5\nbaseline_m = 0.12\n";

std::vector<std::uint8_t> message_bytes(int width, int height, int channels, int imu_samples) {
  Image<std::uint8_t> left(width, height, channels), right(width, height, channels);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width * channels; ++x) {
      left.row(y)[x] = static_cast<std::uint8_t>(x * 7 + y * 3);
      right.row(y)[x] = static_cast<std::uint8_t>(x * 7 + y * 3 + 21);
    }
  std::vector<drivers::ImuSample> imu(static_cast<std::size_t>(imu_samples));
  for (int i = 0; i < imu_samples; ++i) {
    imu[static_cast<std::size_t>(i)].capture_ns = 1'000'000 + i * 1'000'000;
    imu[static_cast<std::size_t>(i)].accel_mps2 = {0.1f, -9.8f, 0.2f};
    imu[static_cast<std::size_t>(i)].gyro_radps = {0.01f, 0.0f, -0.02f};
  }
  drivers::StereoFrame frame;
  frame.seq = 7;
  frame.capture_ns = 5'000'000;
  frame.left = left.cview();
  frame.right = right.cview();
  frame.imu = imu;
  ::dco::raw_stereo_t message;
  drivers::RawStereoEncoder(1).encode(frame, kCalibration, message);
  std::vector<std::uint8_t> out(static_cast<std::size_t>(message.getEncodedSize()));
  message.encode(out.data(), 0, static_cast<int>(out.size()));
  return out;
}

}  // namespace

std::vector<std::vector<std::uint8_t>> seeds() {
  return {message_bytes(32, 24, 1, 3), message_bytes(20, 12, 3, 0)};
}

}  // namespace dco::fuzz
