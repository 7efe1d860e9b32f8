#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <vector>

#include "dco/drivers/usb_transport.hpp"
#include "dco/indemind/calibration_blob.hpp"
#include "dco/indemind/stream_control.hpp"

namespace dco::testing {

// A simulated INDEMIND module behind the USB transport seam. It answers UVC probe/commit and the
// extension-unit flash and register commands, and streams what the real module sends: UVC bulk
// payloads of side-by-side frames with the metadata row (a textured box in front of a textured
// wall, rendered through the module's fisheye calibration) and 32-byte IMU reports. Faults are
// injected on request and counted, so tests can check the driver noticed every one.
//
// Time is virtual by default: handle_events() jumps to the next event, so hours of streaming run
// in seconds and every run is the same. With `pace_real_time` it follows CLOCK_MONOTONIC instead.
class SimulatedIndemind final : public drivers::UsbTransport {
 public:
  enum class Fault {
    kShortTransfer,     // one payload arrives truncated: a short frame
    kLostPayload,       // one payload never arrives: a short frame
    kExtraPayload,      // a payload too many before EOF: an oversized frame
    kErrorBit,          // a payload with the UVC error bit
    kBadHeader,         // a payload whose header is garbage
    kTornMetadata,      // the metadata row fails its sanity check
    kDuplicateCounter,  // an extra frame repeats the previous counter
    kSkipCounter,       // the counter jumps (frames lost inside the module); param = frames
    kStall,             // the bulk endpoint halts until cleared
    kSilence,           // nothing on the bulk endpoint for param ms
    kImuShort,          // one IMU transfer shorter than a report
    kImuDuplicate,      // one IMU report sent twice
    kControlBusy,       // the next param extension-unit answers say busy
    kUnplug,            // gone mid-frame; back after param ms (0 = stays away)
    kCounterRestart,    // the module counts on from param frames back (0 = 1000; < 0 = ahead)
    kCorruptCounter,    // one frame's metadata counter reads param off (0 = 50 ahead); the next
                        // is right again
    kEmptyPayload,      // a zero-length transfer in the middle of a frame
    kImuBadTicks,       // one IMU report with garbage ticks (param, or 0xFFFFFFFF when 0)
    kImuTickRace,       // the first report of a frame: counter moved on, ticks not reset
    kImuStall,          // the interrupt endpoint halts until cleared
    kImuSilence,        // no IMU report for param ms
  };
  static constexpr int kFaultKinds = 21;
  static const char* name(Fault f);

  struct Options {
    int usb_speed_mbps = 5000;
    std::string serial = "OV0001";
    indemind::ModuleCalibration calibration;  // default: sim_calibration()
    std::uint32_t payload_bytes = 32768;      // dwMaxPayloadTransferSize it negotiates
    double clock_skew_ppm = 60;               // real frame period vs nominal
    std::int64_t latency_ns = 400'000;        // least transfer delay
    std::int64_t jitter_ns = 300'000;         // extra delay, uniform
    std::int64_t imu_latency_ns = -1;         // delay of an IMU report; < 0: latency_ns / 4
    std::int64_t control_ns = 0;              // how long a control transfer takes to answer
    std::uint16_t first_counter = 65530;      // wraps after a few frames
    // The counter also counts frames it never sends (stream off, silence); false: it stands still.
    bool counter_counts_unsent_frames = true;
    // The counter starts again at first_counter whenever the video stream starts.
    bool counter_restarts_with_stream = false;
    bool pace_real_time = false;
    std::uint32_t seed = 1;
  };

  // What the module did, for comparison with the driver's counters.
  struct Record {
    std::array<std::uint64_t, kFaultKinds> injected{};  // applied, by kind
    std::uint64_t faults_applied() const {
      std::uint64_t n = 0;
      for (auto v : injected) n += v;
      return n;
    }
    std::uint64_t frames_sent = 0;    // frames put on the wire (intact or not)
    std::uint64_t frames_intact = 0;  // frames sent whole and sound
    std::uint64_t frames_hidden = 0;  // counter values that never went on the wire (skips, stalls)
    std::uint64_t imu_reports = 0;
    std::uint64_t flash_writes = 0;  // any command that would write or erase flash
    std::uint64_t transfers_submitted = 0, transfers_completed = 0;
    std::uint64_t opens = 0;
    std::uint64_t commits = 0;           // video streams committed: each start of the stream
    std::uint64_t busy_answers = 0;      // extension-unit answers that said busy
    std::uint64_t control_hotplugs = 0;  // hotplug notes raised inside control transfers
    std::uint64_t expected_lost = 0;     // counter values between consecutive intact frames
    std::uint64_t recoveries = 0;        // replugs followed by a sound frame
    std::int64_t worst_recovery_ns = 0;  // longest replug -> first sound frame
    std::map<int, int> imu_registers;    // last value written per ICM-20602 register
  };

  SimulatedIndemind();
  explicit SimulatedIndemind(Options options);
  ~SimulatedIndemind() override;

  // The calibration the default module carries: 1280×800, f ≈ 697 px, baseline 0.12 m, KB4.
  static indemind::ModuleCalibration sim_calibration();
  // Scene geometry, for checking depth: the box's depth and where it is in the left image.
  static constexpr double kBoxDepthM = 0.9, kWallDepthM = 3.0;

  // drivers::UsbTransport
  std::vector<drivers::UsbDeviceInfo> list(std::uint16_t vendor, std::uint16_t product) override;
  std::unique_ptr<drivers::UsbDevice> open(const drivers::UsbDeviceInfo& device) override;
  void watch_hotplug(std::uint16_t vendor, std::uint16_t product,
                     std::function<void()> on_change) override;
  void handle_events(std::chrono::milliseconds timeout) override;

  // Any thread.
  void inject(Fault fault, int param = 0);
  // Injects a fault, waits until the module has applied it (a busy extension unit: at once),
  // then until it has sent 4 more frames, 3 of them sound. False if that takes longer than
  // `timeout` of real time.
  bool inject_and_settle(Fault fault, int param,
                         std::chrono::milliseconds timeout = std::chrono::seconds(30));
  void set_present(bool present);  // plugged in (true) or not, from now on
  // The link speed the next enumeration reports (a replug into another port or hub).
  void set_usb_speed(int mbps);
  // libusb handles events, hotplug callbacks among them, inside a synchronous transfer. The next
  // `count` control transfers each raise a hotplug note before they answer (a second module
  // plugged in while the driver reads flash).
  void hotplug_in_control(int count);
  // The `nth` control transfer from now (0: the next) meets an unplug: its hotplug note runs
  // inside the transfer, which fails with the device gone; the module is back after `replug_ms`.
  void unplug_in_control(int nth, int replug_ms);
  std::int64_t now_ns() const;
  Record record() const;
  int transfers_in_flight() const;
  // Host time at which the frame with this extended counter started (for clock-map checks).
  std::int64_t frame_start_ns(std::uint64_t extended_counter) const;
  // Host time of the frame start nearest to `host_ns`.
  std::int64_t nearest_frame_start_ns(std::int64_t host_ns) const;

  class Device;

 private:
  struct Stream;
  struct State;
  std::shared_ptr<State> state_;
};

}  // namespace dco::testing
