#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "dco/core/calibration.hpp"
#include "dco/core/image.hpp"

namespace dco::drivers {

// One inertial sample in SI units, in the camera's frame of reference as the device reports it.
struct ImuSample {
  std::int64_t capture_ns = 0;  // CLOCK_MONOTONIC
  std::array<float, 3> accel_mps2{};
  std::array<float, 3> gyro_radps{};
  float temperature_c = 0;
};

// One stereo pair as a camera delivered it. The views belong to the source and are valid during
// the FrameSink::on_frame call only.
struct StereoFrame {
  // 0, 1, 2, ... per source, continuing across stop/start; a replayed log keeps its numbers.
  std::uint64_t seq = 0;
  std::int64_t capture_ns = 0;                // CLOCK_MONOTONIC
  ImageView<const std::uint8_t> left, right;  // raw (rectify with the source's calibration)
  // IMU samples that arrived since the previous frame (empty for sources without an IMU).
  std::span<const ImuSample> imu;
  // The source's frames before this one are no neighbours of it in time (CaptureGaps: a gap in
  // the camera's stream, or another run in a recorded log): depth starts a new sequence here,
  // unless the pipeline's own pace made the gap (runtime.deterministic holds the camera up).
  bool follows_gap = false;
  // A recorded log's frame where another dcod run begins (follows_gap too): the headset started a
  // new sequence there in every mode.
  bool starts_run = false;
};

// What a source says about its device, for DCO_STATUS and the watchdog.
struct SourceStatus {
  enum class State { kStarting, kStreaming, kDisconnected, kError };
  State state = State::kStarting;
  std::string device;    // driver and model
  std::string serial;    // module id where the device has one
  std::string firmware;  // empty when unknown
  int usb_speed_mbps = 0;
  std::string error;  // the last fault, for humans
  // Monotonic counters (frames, drops, faults by kind, reconnects...), in a fixed order.
  std::vector<std::pair<std::string, std::uint64_t>> counters;
};

struct SourceInfo {
  std::string uri;          // as given
  std::string description;  // one line for logs and status ("synthetic hand 640x360 @ 30 fps")
  int width = 0, height = 0, channels = 1;
  double fps = 0;  // pacing; 0 = as fast as the consumer takes frames
  // A disparity search range that covers what the source shows, when it knows (synthetic scenes).
  std::optional<int> max_disparity;
  // A replayed field log: the pipeline keys the headset made its depth with ("key=value" lines).
  std::string recorded_pipeline;
};

// Where a running source delivers. Called on the source's own thread, one call at a time.
class FrameSink {
 public:
  virtual ~FrameSink() = default;
  virtual void on_frame(const StereoFrame& frame) = 0;
  // A finite source (a replay without loop) delivered its last frame.
  virtual void on_end() = 0;
  // The source cannot go on (unreadable file, vanished device); no frame follows.
  virtual void on_error(const std::string& message) = 0;
};

// A camera or a stand-in for one (architecture § Interfaces). Frames come from buffers the
// source owns, so the steady state allocates nothing.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual const SourceInfo& info() const = 0;
  // The calibration of the delivered frames (raw or already rectified).
  virtual const StereoCalibration& calibration() const = 0;
  // Starts delivering on a thread of the source's own. Throws dco::Error when already running.
  virtual void start(FrameSink& sink) = 0;
  // Stops and joins; no sink call happens after it returns. A stopped source can start again and
  // goes on where it stopped.
  virtual void stop() = 0;
  // Any thread. Sources without a device (files, synthetic scenes) stream while started.
  virtual SourceStatus status() const;
};

// Opens a source by URI:
//   synthetic://NAME?width=W&height=H&fps=F&frames=N&color=0|1&stall_after=N
//   replay://DIR?fps=F&loop=0|1
//   lcmlog://FILE?fps=F&channel=DCO_RAW&run=N  (raw pairs an LCM log recorded; N: one dcod run)
//   indemind://[MODULE_ID]?width=W&height=H&fps=F&imu_hz=HZ&transfers=N&stall_ms=MS
//   libcamera://LEFT_ID,RIGHT_ID?... or libcamera://ID?layout=sbs&... (builds with libcamera)
// Throws dco::Error with a one-line reason for an unknown scheme, unknown or bad parameters, a
// missing or unreadable recording and for cameras this build cannot open; never falls back to
// another source.
std::unique_ptr<FrameSource> open_source(std::string_view uri);
// The checks open_source makes before it opens anything: "scheme://..." with well-formed
// parameters and a scheme this build can open. Throws dco::Error like open_source; a source's own
// parameters are checked when it opens.
void check_source_uri(std::string_view uri);

}  // namespace dco::drivers
