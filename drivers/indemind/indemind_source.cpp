#include "dco/drivers/indemind_source.hpp"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <ctime>
#include <exception>
#include <limits>
#include <mutex>
#include <optional>
#include <thread>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "dco/core/error.hpp"
#include "dco/core/thread_name.hpp"
#include "dco/drivers/capture_gaps.hpp"
#include "dco/indemind/clock_map.hpp"
#include "dco/indemind/frame_assembler.hpp"
#include "dco/indemind/frame_metadata.hpp"
#include "dco/indemind/imu_report.hpp"
#include "dco/indemind/stream_control.hpp"
#include "module_calibration.hpp"
#include "module_control.hpp"

namespace dco::drivers {
namespace {

using namespace indemind;

constexpr std::chrono::milliseconds kEventSlice{20};
constexpr std::int64_t kReopenEveryNs = 250'000'000;
constexpr std::size_t kMaxQueuedImu = 8192;
// How far before the host clock a sample's device time may map: beyond it the counter or ticks
// that placed it are garbage (the metadata row and IMU reports carry no checksum).
constexpr std::int64_t kLeadNs = 50'000'000;
// How far behind it: no sample waits this long in a queue, so a device time that maps there is
// garbage (an IMU report) or of another time line (a frame after the counter stood still).
constexpr std::int64_t kLagNs = 1'000'000'000;
// Frames that all arrive more than the lead after their device time maps to, over this much
// device time, put the map's offsets on another time line: the counter stood still for a while
// (a pause shorter than kLagNs), not a host hiccup, which delays a few frames. One bucket of the
// clock map.
constexpr std::int64_t kLateSpanNs = 250'000'000;
// A frame whose counter leaves the time line is held; a next frame at most this many counts on
// (one or two lost between them) may confirm it as the start of a new time line.
constexpr std::uint16_t kRunMaxStep = 3;
// Protocol notes §7.1: the counter can move on before the ticks reset; the vendor SDK then
// takes 0.1 ms into the frame.
constexpr std::uint32_t kRaceTicks = 16'000;
constexpr std::int64_t kRaceSlackNs = 3'000'000;
constexpr double kStandardGravity = 9.80665;
constexpr double kRadPerDegree = 3.14159265358979323846 / 180.0;

std::int64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

// Every fault the driver can see, counted where it is seen. A frame is either taken (`frames`) or
// dropped and counted once, when it comes: a frame held to see whether the counter left the time
// line for good counts as `implausible_counters` (or `backward_frames`, a counter a little behind)
// whether or not the next frame confirms it, so a single wrong counter and the frame that opens a
// new time line (`counter_restarts`) each cost one there.
struct Counters {
  std::atomic<std::uint64_t> frames{0}, delivered{0}, delivery_drops{0};
  std::atomic<std::uint64_t> lost_frames{0}, duplicate_frames{0}, backward_frames{0};
  std::atomic<std::uint64_t> counter_restarts{0}, torn_frames{0}, implausible_counters{0};
  std::atomic<std::uint64_t> clock_resets{0};
  std::atomic<std::uint64_t> empty_payloads{0}, bad_payloads{0}, short_frames{0};
  std::atomic<std::uint64_t> oversized_frames{0};
  std::atomic<std::uint64_t> error_frames{0}, corrupt_frames{0};
  std::atomic<std::uint64_t> stalls{0}, transfer_errors{0}, stream_restarts{0};
  std::atomic<std::uint64_t> imu_samples{0}, imu_bad_reports{0}, imu_duplicates{0};
  std::atomic<std::uint64_t> imu_out_of_order{0}, imu_overflow{0}, imu_implausible{0};
  std::atomic<std::uint64_t> imu_tick_clamps{0}, imu_silences{0}, imu_before_first_frame{0};
  std::atomic<std::uint64_t> disconnects{0}, reconnects{0}, control_busy{0};
};

class IndemindSource final : public FrameSource {
 public:
  IndemindSource(std::unique_ptr<UsbTransport> transport, IndemindOptions options, std::string uri)
      : transport_(std::move(transport)), options_(std::move(options)) {
    if (!options_.clock) options_.clock = monotonic_ns;
    info_.uri = std::move(uri);
    open_first();
    info_.width = mode_.width;
    info_.height = mode_.height;
    info_.channels = 1;
    info_.fps = mode_.fps;
    stream_fps_ = mode_.fps;
    info_.description = fmt::format(
        "INDEMIND {} {}x{} @ {} fps{}", module_.info.id, mode_.width, mode_.height, mode_.fps,
        options_.imu_hz > 0 ? fmt::format(" + IMU {} Hz", options_.imu_hz) : std::string());
    // Five frame buffers rotate between assembler, event thread, slot and delivery: no
    // allocation per frame.
    assembler_.emplace(mode_.frame_bytes());
    spare_.resize(mode_.frame_bytes());
    slot_.buffer.resize(mode_.frame_bytes());
    deliver_.buffer.resize(mode_.frame_bytes());
    imu_pending_.reserve(kMaxQueuedImu);
    slot_.imu.reserve(kMaxQueuedImu);
    deliver_.imu.reserve(kMaxQueuedImu);
    transport_->watch_hotplug(kVendorId, kProductId, [this] { hotplug_note_ = true; });
  }

  ~IndemindSource() override {
    stop();
    device_.reset();
  }

  const SourceInfo& info() const override { return info_; }
  const StereoCalibration& calibration() const override { return calibration_; }

  void start(FrameSink& sink) override {
    if (running_) throw Error("indemind: source already started");
    sink_ = &sink;
    running_ = true;
    try {
      delivery_ = std::thread([this] {
        name_this_thread("dco-usb-deliver");
        delivery_loop();
      });
      events_ = std::thread([this] {
        name_this_thread("dco-usb-events");
        event_loop();
      });
    } catch (...) {
      // A thread that cannot be created (the unit's TasksMax): the start fails, and the one
      // already running is stopped, not left to end the process when the source goes.
      stop();
      throw;
    }
  }

  void stop() override {
    if (!running_.exchange(false)) return;
    {
      // Under the lock, so the delivery thread cannot miss the wake-up between test and wait.
      std::lock_guard lock(slot_mutex_);
    }
    slot_cv_.notify_all();
    slot_free_cv_.notify_all();
    if (events_.joinable()) events_.join();
    if (delivery_.joinable()) delivery_.join();
  }

  SourceStatus status() const override {
    SourceStatus s;
    s.state = state_.load();
    // The rate streamed now: a replug into a port of another speed may have changed it since
    // info() was made.
    s.device = fmt::format(
        "{}, {}x{} @ {} fps{}", describe(module_.info), mode_.width, mode_.height,
        stream_fps_.load(),
        options_.imu_hz > 0 ? fmt::format(" + IMU {} Hz", options_.imu_hz) : std::string());
    s.serial = module_.info.id;
    s.firmware = module_.info.firmware_version;
    s.usb_speed_mbps = usb_speed_.load();
    {
      std::lock_guard lock(error_mutex_);
      s.error = error_;
    }
    const Counters& c = counters_;
    s.counters = {{"frames", c.frames},
                  {"delivered", c.delivered},
                  {"delivery_drops", c.delivery_drops},
                  {"lost_frames", c.lost_frames},
                  {"duplicate_frames", c.duplicate_frames},
                  {"backward_frames", c.backward_frames},
                  {"counter_restarts", c.counter_restarts},
                  {"torn_frames", c.torn_frames},
                  {"implausible_counters", c.implausible_counters},
                  {"clock_resets", c.clock_resets},
                  {"empty_payloads", c.empty_payloads},
                  {"bad_payloads", c.bad_payloads},
                  {"short_frames", c.short_frames},
                  {"oversized_frames", c.oversized_frames},
                  {"error_frames", c.error_frames},
                  {"corrupt_frames", c.corrupt_frames},
                  {"stalls", c.stalls},
                  {"transfer_errors", c.transfer_errors},
                  {"stream_restarts", c.stream_restarts},
                  {"imu_samples", c.imu_samples},
                  {"imu_bad_reports", c.imu_bad_reports},
                  {"imu_duplicates", c.imu_duplicates},
                  {"imu_out_of_order", c.imu_out_of_order},
                  {"imu_overflow", c.imu_overflow},
                  {"imu_implausible", c.imu_implausible},
                  {"imu_tick_clamps", c.imu_tick_clamps},
                  {"imu_silences", c.imu_silences},
                  {"imu_before_first_frame", c.imu_before_first_frame},
                  {"disconnects", c.disconnects},
                  {"reconnects", c.reconnects},
                  {"control_busy", c.control_busy}};
    return s;
  }

 private:
  // Opening ---------------------------------------------------------------------------------

  void open_first() {
    std::vector<UsbDeviceInfo> found = transport_->list(kVendorId, kProductId);
    if (found.empty())
      throw Error(
          "indemind: no INDEMIND module (USB 05a9:f581) found; check the cable and that this "
          "user may access it (udev rule, group dcod)");
    std::vector<std::string> ids;
    std::vector<std::string> unreadable;
    std::exception_ptr first_failure;
    for (const UsbDeviceInfo& d : found) {
      std::unique_ptr<UsbDevice> device;
      ModuleCalibration m;
      try {
        m = open_module(d, device);
      } catch (const std::exception& e) {
        // One held by another program, or one that just left: the next may be the one asked for.
        if (!first_failure) first_failure = std::current_exception();
        unreadable.push_back(e.what());
        continue;
      }
      if (!options_.module_id.empty() && m.info.id != options_.module_id) {
        ids.push_back(m.info.id);
        other_modules_.push_back(bus_address(d));
        continue;
      }
      choose_mode(d.speed_mbps);
      calibration_ = to_stereo_calibration(m, mode_.width, mode_.height);
      module_ = std::move(m);
      usb_speed_ = d.speed_mbps;
      port_path_ = d.port_path;
      device_ = std::move(device);
      return;
    }
    if (ids.empty() && unreadable.size() == 1) std::rethrow_exception(first_failure);
    for (const std::string& why : unreadable) ids.push_back("one unreadable: " + why);
    if (options_.module_id.empty())
      throw Error(fmt::format("indemind: no module could be opened ({})", fmt::join(ids, "; ")));
    throw Error(fmt::format("indemind: no module with id '{}' (found: {})", options_.module_id,
                            fmt::join(ids, ", ")));
  }

  // Opens a listed module into `device` and reads its flash.
  ModuleCalibration open_module(const UsbDeviceInfo& d, std::unique_ptr<UsbDevice>& device) {
    device = transport_->open(d);
    return read_module(*device);
  }

  ModuleCalibration read_module(UsbDevice& device) {
    for (int i = 0; i < 3; ++i) device.claim_interface(i);
    ModuleControl control(device);
    ModuleCalibration m = control.read_calibration();
    counters_.control_busy += control.busy_retries();
    return m;
  }

  void choose_mode(int speed) {
    std::string why;
    const std::optional<StreamMode> m = mode_for(speed, why);
    if (!m) throw Error("indemind: " + why);
    mode_ = *m;
  }

  // The mode the options ask for on a link of `speed`: the default's size and rate where they
  // name none. nullopt with `why` filled when the link cannot carry it.
  std::optional<StreamMode> mode_for(int speed, std::string& why) const {
    const StreamMode d = default_stream_mode(speed);
    if (options_.width == 0 && options_.height == 0 && options_.fps == 0) return d;
    // A width or height alone names its mode's size.
    const bool no_size = options_.width == 0 && options_.height == 0;
    return find_stream_mode(no_size ? d.width : options_.width,
                            no_size ? d.height : options_.height,
                            options_.fps ? options_.fps : d.fps, speed, why);
  }

  using BusAddress = std::pair<int, int>;
  static BusAddress bus_address(const UsbDeviceInfo& d) { return {d.bus, d.address}; }
  bool is_other_module(const UsbDeviceInfo& d) const {
    return std::find(other_modules_.begin(), other_modules_.end(), bus_address(d)) !=
           other_modules_.end();
  }

  // The module came back (or another one arrived): take it only if it is the same module.
  void try_reopen() {
    std::vector<UsbDeviceInfo> found = transport_->list(kVendorId, kProductId);
    // A module once read as another one stays another one until it leaves the bus (a replug
    // gives a new address): opening it again would take it from whoever uses it, since claiming
    // detaches its kernel driver.
    std::erase_if(other_modules_, [&](const BusAddress& a) {
      return std::none_of(found.begin(), found.end(),
                          [&](const UsbDeviceInfo& d) { return bus_address(d) == a; });
    });
    std::erase_if(found, [&](const UsbDeviceInfo& d) { return is_other_module(d); });
    // Its own socket first: a module replugged there is found without opening the others.
    std::stable_partition(found.begin(), found.end(),
                          [&](const UsbDeviceInfo& d) { return d.port_path == port_path_; });
    for (const UsbDeviceInfo& d : found) {
      std::unique_ptr<UsbDevice> device;
      ModuleCalibration m;
      try {
        m = open_module(d, device);
      } catch (const std::exception& e) {
        set_error(std::string("reopening: ") + e.what());
        continue;
      }
      if (!(m == module_)) {
        other_modules_.push_back(bus_address(d));
        set_error(fmt::format("a different module ('{}') was plugged in; waiting for '{}'",
                              m.info.id, module_.info.id));
        continue;
      }
      // Back on a slower (or faster) link: the rate that link carries at the same size, unless
      // a rate was asked for. A size the link cannot carry at all would change the calibration;
      // the module is then left alone until it is plugged in again.
      std::string why;
      const std::optional<StreamMode> mode = mode_for(d.speed_mbps, why);
      if (!mode || mode->width != mode_.width || mode->height != mode_.height) {
        if (mode) why = fmt::format("this link carries {}, not {}", mode->name(), mode_.name());
        other_modules_.push_back(bus_address(d));
        set_error(fmt::format("replugged at {} Mb/s: {}; waiting for it on another port",
                              d.speed_mbps, why));
        continue;
      }
      // Only the rate changes: the size the delivery thread reads stays as it is.
      mode_.fps = mode->fps;
      mode_.frame_index = mode->frame_index;
      stream_fps_ = mode->fps;
      device_ = std::move(device);
      usb_speed_ = d.speed_mbps;
      port_path_ = d.port_path;
      // A replugged module counts frames from anywhere: start_streaming() starts a new time line.
      ++counters_.reconnects;
      state_ = SourceStatus::State::kStarting;
      return;
    }
  }

  // Streaming -------------------------------------------------------------------------------

  void start_streaming() {
    ModuleControl control(*device_);
    const StreamControl committed = control.negotiate(mode_);
    if (options_.imu_hz > 0) control.configure_imu(options_.imu_hz, ranges_);
    counters_.control_busy += control.busy_retries();
    assembler_->reset();
    // A started stream (after a stall, a silence, an error or a replug) may count from anywhere:
    // the module may start its counter again, or have counted frames it never sent. Its first
    // frame is a first one, on a new time line.
    extender_.resync();
    new_time_line();
    have_last_report_ = false;
    device_->start_in_stream(
        kVideoEndpoint, EndpointType::kBulk, committed.max_payload_transfer_size,
        options_.transfers,
        [this](TransferStatus s, std::span<const std::uint8_t> d) { on_video(s, d); });
    if (options_.imu_hz > 0)
      device_->start_in_stream(
          kImuEndpoint, EndpointType::kInterrupt, 64, 4,
          [this](TransferStatus s, std::span<const std::uint8_t> d) { on_imu(s, d); });
    streaming_ = true;
    restart_ = false;
    last_frame_ns_ = options_.clock();
    last_imu_report_ns_ = last_frame_ns_;
    imu_seen_ = false;
  }

  // The device time line starts again (a started stream, a counter that restarted): what the
  // clock map, the IMU order and a held frame learnt from the old one no longer applies. The
  // stamps' floors stay: a new line starts near the host clock, at most the lead behind the old
  // one's last stamp, and a consumer must never see a stamp again.
  void new_time_line() {
    clock_.reset();
    last_imu_device_ns_ = -1;
    held_.reset();
    late_since_device_ns_.reset();
  }

  std::int64_t lead_ns() const { return std::max(kLeadNs, frames_ns(2)); }

  // A slow IMU leaves gaps between reports longer than stall_ms; only three missed in a row are
  // a silence.
  std::int64_t imu_silence_ns() const {
    const std::int64_t stall = std::int64_t{options_.stall_ms} * 1'000'000;
    if (options_.imu_hz <= 0) return stall;  // no IMU stream asked for
    return std::max(stall, 3 * std::int64_t{1'000'000'000} / options_.imu_hz);
  }

  // Whether a device time maps more than the lead ahead of the host clock `now`, or more than
  // kLagNs behind it.
  bool ahead_of_host(std::int64_t device_ns, std::int64_t now) const {
    return clock_.buckets() > 0 && clock_.to_host(device_ns) > now + lead_ns();
  }
  bool behind_host(std::int64_t device_ns, std::int64_t now) const {
    return clock_.buckets() > 0 && clock_.to_host(device_ns) < now - kLagNs;
  }

  void stop_streaming() {
    if (device_) device_->stop_streams();
    streaming_ = false;
    assembler_->reset();
  }

  void drop_device() {
    stop_streaming();
    device_.reset();
    gone_ = false;
    state_ = SourceStatus::State::kDisconnected;
    ++counters_.disconnects;
    set_error("module unplugged; waiting for it to come back");
  }

  void event_loop() {
    std::int64_t next_reopen = 0;
    while (running_ && !transport_->finished()) {
      try {
        step(next_reopen);
      } catch (const UsbError& e) {
        if (e.no_device()) {
          if (device_) drop_device();
        } else {
          set_error(e.what());
          if (device_) stop_streaming();
          state_ = SourceStatus::State::kError;
          next_reopen = options_.clock() + kReopenEveryNs;
        }
      } catch (const std::exception& e) {
        set_error(e.what());
        if (device_) stop_streaming();
        state_ = SourceStatus::State::kError;
        next_reopen = options_.clock() + kReopenEveryNs;
      }
    }
    try {
      stop_streaming();
    } catch (const std::exception& e) {
      set_error(e.what());
    }
    if (transport_->finished()) {
      // A recording played to its end: the frame in the slot still goes out, then the end.
      std::string why = transport_->finish_error();
      if (!why.empty()) set_error(why);
      {
        std::lock_guard lock(slot_mutex_);
        ended_ = true;
        end_error_ = std::move(why);
      }
      slot_cv_.notify_all();
    }
  }

  void step(std::int64_t& next_retry) {
    const std::int64_t now = options_.clock();
    if (!device_) {
      if (hotplug_note_.exchange(false) || now >= next_retry) {
        next_retry = now + kReopenEveryNs;
        try_reopen();
      }
    } else if (!streaming_ && now >= next_retry) {
      start_streaming();
    }
    transport_->handle_events(kEventSlice);
    if (!device_) return;
    hotplug_note_ = false;  // the module in hand is fine; its departure shows as kNoDevice
    if (gone_) {
      drop_device();
      return;
    }
    if (!streaming_) return;
    const std::int64_t stall_ns = std::int64_t{options_.stall_ms} * 1'000'000;
    const std::int64_t after = options_.clock();
    const bool stalled = after - last_frame_ns_ > stall_ns;
    // Armed by a first report: a module that sends no IMU at all must not lose its video.
    const bool imu_silent = imu_seen_ && after - last_imu_report_ns_ > imu_silence_ns();
    if (restart_ || stalled || imu_silent) {
      if (stalled) {
        set_error(fmt::format("no frame for {} ms; restarting the stream", options_.stall_ms));
      } else if (imu_silent && !restart_) {
        ++counters_.imu_silences;
        set_error(fmt::format("no IMU report for {} ms; restarting the stream",
                              imu_silence_ns() / 1'000'000));
      }
      ++counters_.stream_restarts;
      stop_streaming();
      device_->clear_halt(kVideoEndpoint);
      if (options_.imu_hz > 0) device_->clear_halt(kImuEndpoint);
      start_streaming();
    }
  }

  void on_video(TransferStatus status, std::span<const std::uint8_t> data) {
    switch (status) {
      case TransferStatus::kCompleted:
        if (std::int64_t first_ns = 0;
            assembler_->feed(data, options_.clock()) && assembler_->take_frame(spare_, &first_ns))
          accept_frame(first_ns);
        sync_assembler_counters();
        break;
      case TransferStatus::kStall:
        ++counters_.stalls;
        restart_ = true;
        break;
      case TransferStatus::kNoDevice:
        gone_ = true;
        break;
      case TransferStatus::kCancelled:
        break;
      case TransferStatus::kTimedOut:
      case TransferStatus::kOverflow:
      case TransferStatus::kError:
        ++counters_.transfer_errors;
        // The frame in progress lost bytes somewhere.
        assembler_->reset();
        break;
    }
  }

  void sync_assembler_counters() {
    // One assembler lives as long as the source, so its counts are totals; the atomics make them
    // readable from status().
    const AssemblerCounters& a = assembler_->counters();
    counters_.empty_payloads = a.empty_payloads;
    counters_.bad_payloads = a.bad_payloads;
    counters_.short_frames = a.short_frames;
    counters_.oversized_frames = a.oversized_frames;
    counters_.error_frames = a.error_frames;
    counters_.corrupt_frames = a.corrupt_frames;
  }

  // `first_ns`: host arrival of the frame's first payload.
  void accept_frame(std::int64_t first_ns) {
    const std::size_t row = std::size_t(2) * mode_.width;
    std::span<std::uint8_t> last(spare_.data() + (mode_.height - 1) * row, row);
    const FrameMetadata meta = parse_frame_metadata(last);
    if (meta.torn) {
      ++counters_.torn_frames;
      return;
    }
    const auto step = extender_.classify(meta.counter);
    const std::int64_t now = options_.clock();
    bool fits = true;
    switch (step.step) {
      case CounterExtender::Step::kDuplicate:
        ++counters_.duplicate_frames;
        return;
      case CounterExtender::Step::kBackward:
      case CounterExtender::Step::kRestart:
        fits = false;
        break;
      case CounterExtender::Step::kGap:
        // Frames lost inside the module or on the bus leave as many periods between arrivals as
        // the counter steps; a corrupt counter a few counts high does not: taking it would stamp
        // the frame late, drop the frames after it as backward and bend the clock map.
        fits = arrived_as_counted(step.extended, first_ns);
        break;
      case CounterExtender::Step::kFirst:
      case CounterExtender::Step::kNext:
        break;
    }
    CounterExtender::Result taken = step;
    if (fits) {
      counters_.lost_frames += step.skipped;
    } else if (const std::uint16_t on = counts_past_held(meta.counter, first_ns); on > 0) {
      // Two frames agree with each other and not with the time line: the module counts from
      // elsewhere now (its counter restarted, or the time line was set by a stale first frame).
      counters_.lost_frames += on - 1u;
      ++counters_.counter_restarts;
      extender_.resync();
      taken = extender_.classify(meta.counter);
      new_time_line();
    } else {
      // No checksum tells a corrupt counter from the first of a new time line: one frame never
      // moves the time line (and the clock map with it); it waits for a second that agrees.
      held_ = Held{meta.counter, first_ns};
      ++(step.step == CounterExtender::Step::kBackward ? counters_.backward_frames
                                                       : counters_.implausible_counters);
      return;
    }
    held_.reset();
    extender_.accept(taken);
    last_taken_first_ns_ = first_ns;
    if (taken.step == CounterExtender::Step::kFirst) {
      // Each time line places its first value up to 2^17 above the last: counted from zero,
      // device times would overflow after some 10^5 restarts. The margin keeps IMU reports of
      // the frames before it (placed at most 2^15 back) above the origin.
      origin_ = taken.extended - std::min<std::uint64_t>(taken.extended, 1u << 16);
    }
    mask_frame_metadata(last, std::span<const std::uint8_t>(last.data() - row, row));
    const std::int64_t device_ns = frame_device_ns(taken.extended);
    if (behind_host(device_ns, now) || late_for_a_bucket(device_ns, first_ns)) {
      // The counter stood still while the host clock ran on (a module that stops counting while
      // it is not streaming): the map's offsets are of another time line now.
      ++counters_.clock_resets;
      new_time_line();
    }
    // The first payload's arrival: the last one's adds a readout to the delay, and the map's
    // lower envelope would jump by that wherever IMU samples are missing from a bucket.
    clock_.add(device_ns, first_ns);
    last_frame_ns_ = now;
    ++counters_.frames;
    state_ = SourceStatus::State::kStreaming;
    {
      std::unique_lock lock(slot_mutex_);
      if (options_.lossless) slot_free_cv_.wait(lock, [this] { return !slot_.full || !running_; });
      if (slot_.full) ++counters_.delivery_drops;
      std::swap(slot_.buffer, spare_);
      slot_.capture_ns = rising(clock_.to_host(device_ns), last_frame_capture_ns_);
      // Samples of a frame the consumer never took still belong to the time line: keep them. A
      // consumer held up past kMaxQueuedImu of them gets the newest (what a tracker resumes
      // from); each one dropped is counted.
      const std::size_t total = slot_.imu.size() + imu_pending_.size();
      const std::size_t drop = total > kMaxQueuedImu ? total - kMaxQueuedImu : 0;
      const std::size_t from_slot = std::min(drop, slot_.imu.size());
      slot_.imu.erase(slot_.imu.begin(),
                      slot_.imu.begin() + static_cast<std::ptrdiff_t>(from_slot));
      slot_.imu.insert(slot_.imu.end(),
                       imu_pending_.begin() + static_cast<std::ptrdiff_t>(drop - from_slot),
                       imu_pending_.end());
      counters_.imu_overflow += drop;
      imu_pending_.clear();
      slot_.full = true;
    }
    slot_cv_.notify_one();
  }

  // Whether frames have arrived more than the lead after the host time their device time maps
  // to for kLateSpanNs of device time, this one included.
  bool late_for_a_bucket(std::int64_t device_ns, std::int64_t first_ns) {
    if (clock_.buckets() == 0 || first_ns - clock_.to_host(device_ns) <= lead_ns()) {
      late_since_device_ns_.reset();
      return false;
    }
    if (!late_since_device_ns_) late_since_device_ns_ = device_ns;
    return device_ns - *late_since_device_ns_ >= kLateSpanNs;
  }

  // Nominal duration of `n` frames.
  std::int64_t frames_ns(std::int64_t n) const { return n * 1'000'000'000 / mode_.fps; }
  std::int64_t frame_device_ns(std::uint64_t extended) const {
    return frames_ns(static_cast<std::int64_t>(extended - origin_));
  }

  // Whether a frame at `extended` arrived (its first payload at `first_ns`) as many frame periods
  // after the last frame taken as the counter stepped. Judged against the clock map where it has
  // learnt something: its lower envelope is the earliest a frame's first payload arrives, so a
  // frame lost before this one leaves its arrival there or later (the host's scheduling only
  // delays it, up to the lead), while a counter a few counts high maps whole periods after its
  // arrival. Two arrivals compared with each other carry the jitter of both, which at 200 fps
  // misjudged real losses for corrupt counters (half a period is 2.5 ms). Without a map: within
  // half a period of the last frame's arrival plus the counted periods, the skew scaling them.
  bool arrived_as_counted(std::uint64_t extended, std::int64_t first_ns) const {
    if (clock_.buckets() > 0) {
      const std::int64_t miss = first_ns - clock_.to_host(frame_device_ns(extended));
      return -2 * miss < frames_ns(1) && miss <= lead_ns();
    }
    const std::int64_t counted = clock_.to_host(frame_device_ns(extended)) -
                                 clock_.to_host(frame_device_ns(extender_.last()));
    const std::int64_t miss = first_ns - last_taken_first_ns_ - counted;
    return 2 * miss < frames_ns(1) && -2 * miss < frames_ns(1);
  }

  // How many counts `counter` is past the held frame if it agrees with it (a few counts on, and
  // arrived as many frame periods after it, within the lead the host clock check allows); 0 if
  // it does not.
  std::uint16_t counts_past_held(std::uint16_t counter, std::int64_t first_ns) const {
    if (!held_) return 0;
    const auto on = static_cast<std::uint16_t>(counter - held_->counter);
    if (on == 0 || on > kRunMaxStep) return 0;
    const std::int64_t miss = first_ns - held_->first_ns - frames_ns(on);
    return miss <= lead_ns() && -miss <= lead_ns() ? on : 0;
  }

  // The clock map moves as it learns (a lower minimum, a new fit) and may map a later device
  // time before an earlier one; the daemon finds a frame by its exact capture time and IMU
  // consumers integrate in order, so each stream's stamps only rise.
  static std::int64_t rising(std::int64_t stamp, std::int64_t& last) {
    last = std::max(stamp, last + 1);
    return last;
  }

  void on_imu(TransferStatus status, std::span<const std::uint8_t> data) {
    if (status == TransferStatus::kNoDevice) {
      gone_ = true;
      return;
    }
    if (status == TransferStatus::kCancelled) return;
    if (status == TransferStatus::kStall) {
      // The transfer rests until the halt is cleared: restart as for the video endpoint.
      ++counters_.stalls;
      restart_ = true;
      return;
    }
    if (status != TransferStatus::kCompleted) {
      ++counters_.transfer_errors;
      return;
    }
    const std::int64_t now = options_.clock();
    last_imu_report_ns_ = now;
    imu_seen_ = true;
    const auto report = parse_imu_report(data);
    if (!report) {
      ++counters_.imu_bad_reports;
      return;
    }
    if (have_last_report_ && report->frame_counter == last_report_.frame_counter &&
        report->ticks == last_report_.ticks) {
      ++counters_.imu_duplicates;
      return;
    }
    last_report_ = *report;
    have_last_report_ = true;
    if (!extender_.started()) {
      // Samples before the first frame have no place on the frame counter's time line yet.
      ++counters_.imu_before_first_frame;
      return;
    }
    const std::uint64_t placed = extender_.place(report->frame_counter);
    auto device_ns_of = [&](std::uint32_t ticks) {
      return frame_device_ns(placed) +
             static_cast<std::int64_t>(ticks * (1e9 / kImuTicksPerSecond));
    };
    std::int64_t device_ns = device_ns_of(report->ticks);
    // Ticks that ran on from the previous frame are below two frame periods; more is garbage,
    // even where it would still map near the host clock (it would bend the clock map).
    const double race_ticks_max = 2.0 * kImuTicksPerSecond / mode_.fps;
    if (report->ticks >= race_ticks_max) {
      ++counters_.imu_implausible;
      return;
    }
    if (last_imu_device_ns_ >= 0 && placed > last_imu_placed_ && report->ticks >= last_imu_ticks_ &&
        report->ticks < race_ticks_max &&
        device_ns - last_imu_device_ns_ > now - last_imu_host_ns_ + kRaceSlackNs) {
      // The counter moved on but the ticks did not reset: the sample is near the frame start.
      ++counters_.imu_tick_clamps;
      device_ns = device_ns_of(kRaceTicks);
    }
    if (ahead_of_host(device_ns, now) || behind_host(device_ns, now)) {
      ++counters_.imu_implausible;
      return;
    }
    if (device_ns <= last_imu_device_ns_) {
      ++counters_.imu_out_of_order;
      return;
    }
    last_imu_device_ns_ = device_ns;
    last_imu_host_ns_ = now;
    last_imu_placed_ = placed;
    last_imu_ticks_ = report->ticks;
    clock_.add(device_ns, now);
    const indemind::ImuSample scaled = to_sample(*report, ranges_);
    drivers::ImuSample s;
    s.capture_ns = rising(clock_.to_host(device_ns), last_imu_capture_ns_);
    for (int i = 0; i < 3; ++i) {
      s.accel_mps2[i] = static_cast<float>(scaled.accel_g[i] * kStandardGravity);
      s.gyro_radps[i] = static_cast<float>(scaled.gyro_dps[i] * kRadPerDegree);
    }
    s.temperature_c = scaled.temperature_c;
    ++counters_.imu_samples;
    if (imu_pending_.size() >= kMaxQueuedImu) {
      ++counters_.imu_overflow;
      return;
    }
    imu_pending_.push_back(s);
  }

  // Delivery --------------------------------------------------------------------------------

  void delivery_loop() {
    while (true) {
      {
        std::unique_lock lock(slot_mutex_);
        slot_cv_.wait(lock, [this] { return slot_.full || !running_ || ended_; });
        if (!running_) return;
        if (!slot_.full) {
          lock.unlock();
          if (end_error_.empty())
            sink_->on_end();
          else
            sink_->on_error(end_error_);
          return;
        }
        std::swap(slot_.buffer, deliver_.buffer);
        std::swap(slot_.imu, deliver_.imu);
        slot_.imu.clear();
        deliver_.capture_ns = slot_.capture_ns;
        slot_.full = false;
      }
      slot_free_cv_.notify_one();
      const int w = mode_.width, h = mode_.height;
      const std::uint8_t* row0 = deliver_.buffer.data();
      const bool swap = swaps_halves(module_.module_type);
      StereoFrame f;
      f.seq = seq_++;
      f.capture_ns = deliver_.capture_ns;
      f.follows_gap = gaps_.follows_gap(f.capture_ns);
      f.left = ImageView<const std::uint8_t>(row0 + (swap ? w : 0), w, h, 1, 2 * w);
      f.right = ImageView<const std::uint8_t>(row0 + (swap ? 0 : w), w, h, 1, 2 * w);
      f.imu = deliver_.imu;
      try {
        sink_->on_frame(f);
      } catch (const std::exception& e) {
        // As every source does: the sink's failure ends the delivery, reported, not thrown out
        // of this thread (which would terminate the process).
        sink_->on_error(e.what());
        return;
      }
      ++counters_.delivered;
    }
  }

  void set_error(std::string message) {
    std::lock_guard lock(error_mutex_);
    error_ = std::move(message);
  }

  struct Slot {
    std::vector<std::uint8_t> buffer;
    std::vector<drivers::ImuSample> imu;
    std::int64_t capture_ns = 0;
    bool full = false;
  };

  std::unique_ptr<UsbTransport> transport_;
  IndemindOptions options_;
  SourceInfo info_;
  StereoCalibration calibration_;
  ModuleCalibration module_;
  // Where the module was last found, and modules read as others; the event thread's alone.
  std::string port_path_;
  std::vector<BusAddress> other_modules_;
  StreamMode mode_;
  ImuRanges ranges_;
  std::unique_ptr<UsbDevice> device_;
  std::atomic<int> usb_speed_{0};
  std::atomic<int> stream_fps_{0};  // mode_.fps, for status() on other threads

  // Event thread only.
  std::optional<FrameAssembler> assembler_;  // sized once the mode is known
  CounterExtender extender_;
  ClockMap clock_;
  std::vector<std::uint8_t> spare_;
  std::vector<drivers::ImuSample> imu_pending_;
  ImuReport last_report_;
  bool have_last_report_ = false;
  std::int64_t last_imu_device_ns_ = -1, last_frame_ns_ = 0;
  // The first payload's arrival of the last frame taken: a counter gap must agree with it.
  std::int64_t last_taken_first_ns_ = 0;
  // Device time of the first of the frames that have all arrived late since (late_for_a_bucket).
  std::optional<std::int64_t> late_since_device_ns_;
  // The last IMU sample taken (for the tick race) and the last report of any kind (for silence).
  std::int64_t last_imu_host_ns_ = 0, last_imu_report_ns_ = 0;
  std::uint64_t last_imu_placed_ = 0;
  std::uint32_t last_imu_ticks_ = 0;
  // Floors of the stamps of each stream: what the last frame and IMU sample got.
  std::int64_t last_frame_capture_ns_ = std::numeric_limits<std::int64_t>::min();
  std::int64_t last_imu_capture_ns_ = std::numeric_limits<std::int64_t>::min();
  // The last frame whose counter left the time line, with its first payload's arrival.
  struct Held {
    std::uint16_t counter = 0;
    std::int64_t first_ns = 0;
  };
  std::optional<Held> held_;
  std::uint64_t origin_ = 0;  // the extended value at device time 0 of this time line
  bool imu_seen_ = false;
  bool streaming_ = false, restart_ = false, gone_ = false;

  std::atomic<bool> hotplug_note_{false}, running_{false};
  std::atomic<SourceStatus::State> state_{SourceStatus::State::kStarting};
  mutable std::mutex error_mutex_;
  std::string error_;
  Counters counters_;

  std::mutex slot_mutex_;
  std::condition_variable slot_cv_, slot_free_cv_;
  Slot slot_, deliver_;
  bool ended_ = false;  // the transport finished: deliver what is left, then end
  std::string end_error_;
  std::uint64_t seq_ = 0;
  CaptureGaps gaps_;  // the delivery thread's, over the frames delivered
  FrameSink* sink_ = nullptr;
  std::thread events_, delivery_;
};

}  // namespace

std::unique_ptr<FrameSource> open_indemind(std::unique_ptr<UsbTransport> transport,
                                           IndemindOptions options, std::string uri) {
  return std::make_unique<IndemindSource>(std::move(transport), std::move(options), std::move(uri));
}

}  // namespace dco::drivers
