#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "dco/drivers/frame_source.hpp"
#include "dco/drivers/usb_transport.hpp"

namespace dco::drivers {

struct IndemindOptions {
  std::string module_id;  // the flash ModuleInfo id; empty: the one module attached
  // Per eye; 0: 640x400 at 50 fps (25 on USB 2), a width or height alone: its mode's size.
  int width = 0, height = 0, fps = 0;
  int imu_hz = 1000;    // 0: no IMU stream; else divides 1000, at least 4
  int transfers = 8;    // bulk transfers in flight
  int stall_ms = 1000;  // no frame for this long: restart the stream
  // Wait for the consumer instead of replacing a frame it has not taken (replays, where nothing
  // is lost by waiting and every recorded frame should come out).
  bool lossless = false;
  // CLOCK_MONOTONIC by default; a simulated device brings its own clock.
  std::function<std::int64_t()> clock;
};

// The INDEMIND stereo-inertial module over a USB transport. The constructor finds and opens the
// module and reads its calibration from flash (throws dco::Error with one line when there is no
// module, no permission, or no readable calibration). While started it owns one USB event thread
// and one delivery thread; an unplugged module leaves it waiting (state kDisconnected) and the same
// module plugged in again resumes the stream without a restart of the process. A transport that
// finishes (a replayed capture) ends the source after its last frame.
std::unique_ptr<FrameSource> open_indemind(std::unique_ptr<UsbTransport> transport,
                                           IndemindOptions options, std::string uri);

}  // namespace dco::drivers
