#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <vector>

#include "dco/drivers/usb_transport.hpp"
#include "dco/indemind/calibration_blob.hpp"
#include "dco/indemind/imu_report.hpp"
#include "dco/indemind/stream_control.hpp"

namespace dco::indemind {

// Control requests to an opened module: the vendor extension unit (flash reads, IMU registers)
// and UVC probe/commit. Read-only towards flash by construction: xu_task.hpp has no encoder that
// writes or erases it. Throws drivers::UsbError for transport failures and dco::Error when the
// module answers nonsense.
class ModuleControl {
 public:
  explicit ModuleControl(drivers::UsbDevice& device) : device_(device) {}

  std::vector<std::uint8_t> read_flash(std::uint32_t address, std::size_t length);
  ModuleCalibration read_calibration();

  // Sample rate (must divide 1000, at least kMinImuHz) and full-scale ranges of the ICM-20602.
  void configure_imu(int rate_hz, const ImuRanges& ranges);

  // Probe, check what the module offers, commit. Returns the committed control.
  StreamControl negotiate(const StreamMode& mode);

  // Extension-unit answers that said "busy" and were asked again.
  std::uint64_t busy_retries() const { return busy_retries_; }

 private:
  std::vector<std::uint8_t> transaction(const std::vector<std::uint8_t>& command,
                                        std::size_t reply_bytes);

  drivers::UsbDevice& device_;
  std::uint64_t busy_retries_ = 0;
};

}  // namespace dco::indemind
