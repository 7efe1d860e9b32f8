#include <optional>

#include <fmt/format.h>

#include "dco/core/error.hpp"
#include "dco/drivers/indemind_source.hpp"
#include "dco/drivers/usb_capture.hpp"
#include "dco/indemind/imu_report.hpp"
#include "dco/indemind/stream_control.hpp"
#include "src/sources.hpp"

namespace dco::drivers {

std::unique_ptr<FrameSource> open_indemind(SourceUri& uri) {
  IndemindOptions o;
  o.module_id = uri.path();
  o.width = uri.integer("width", 0, 0, 1280);
  o.height = uri.integer("height", 0, 0, 800);
  o.fps = uri.integer("fps", 0, 0, 200);
  o.imu_hz = uri.integer("imu_hz", 1000, 0, 1000);
  if (o.imu_hz > 0 && (1000 % o.imu_hz != 0 || o.imu_hz < indemind::kMinImuHz))
    throw Error(fmt::format(
        "source '{}': imu_hz must divide 1000 and be at least {} (4, 5, 8, 10, ..., 500, 1000), or "
        "0 for no IMU",
        uri.text(), indemind::kMinImuHz));
  o.transfers = uri.integer("transfers", 8, 2, 64);
  o.stall_ms = uri.integer("stall_ms", 1000, 100, 60000);
  const std::optional<std::string> record = uri.value("record");
  const auto record_max_bytes =
      static_cast<std::uint64_t>(
          uri.integer("record_max_mb", static_cast<int>(kDefaultCaptureMaxBytes >> 20), 1, 1 << 20))
      << 20;
  const std::optional<std::string> replay = uri.value("replay");
  uri.finish();
  if (record && replay)
    throw Error(fmt::format("source '{}': record and replay exclude each other", uri.text()));
  if (o.width || o.height || o.fps) {
    // Modes the module never offers are refused before touching USB; the link speed is checked
    // once the module is found.
    std::string why;
    // A width or height alone names its mode's size.
    const bool no_size = o.width == 0 && o.height == 0;
    if (!indemind::find_stream_mode(no_size ? 640 : o.width, no_size ? 400 : o.height,
                                    o.fps ? o.fps : 50, 0, why))
      throw Error(fmt::format("source '{}': {}", uri.text(), why));
  }
  std::unique_ptr<UsbTransport> transport;
  try {
    if (replay) {
      // The capture's own clock, and every recorded frame out, whatever the consumer's pace.
      auto r = open_usb_replay(*replay);
      o.clock = [t = r.get()] { return t->now_ns(); };
      o.lossless = true;
      transport = std::move(r);
    } else {
      transport = make_libusb_transport();
      if (record)
        transport = make_recording_transport(std::move(transport), *record, {}, record_max_bytes);
    }
  } catch (const UsbError& e) {
    throw Error(fmt::format("source '{}': USB unavailable: {}", uri.text(), e.what()));
  } catch (const Error& e) {
    throw Error(fmt::format("source '{}': {}", uri.text(), e.what()));
  }
  try {
    return open_indemind(std::move(transport), std::move(o), uri.text());
  } catch (const Error& e) {
    throw Error(fmt::format("source '{}': {}", uri.text(), e.what()));
  }
}

}  // namespace dco::drivers
