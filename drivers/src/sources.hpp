#pragma once

#include <memory>

#include "dco/drivers/frame_source.hpp"
#include "dco/drivers/source_uri.hpp"

namespace dco::drivers {

// One per scheme; each reads its parameters from the URI and calls uri.finish().
std::unique_ptr<FrameSource> open_synthetic(SourceUri& uri);
std::unique_ptr<FrameSource> open_replay(SourceUri& uri);
// lcmlog://FILE?fps=&channel=: raw pairs recorded on DCO_RAW.
std::unique_ptr<FrameSource> open_lcmlog(SourceUri& uri);
// indemind://[MODULE_ID]?width=&height=&fps=&imu_hz=&transfers=&stall_ms= over libusb.
std::unique_ptr<FrameSource> open_indemind(SourceUri& uri);
// libcamera://LEFT_ID,RIGHT_ID or libcamera://ID?layout=sbs (only when built with libcamera).
std::unique_ptr<FrameSource> open_libcamera(SourceUri& uri);

}  // namespace dco::drivers
