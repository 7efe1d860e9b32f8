// A transport that plays a capture back: it answers the driver's calls with the recorded outcomes
// and delivers the recorded completions at their recorded times on a virtual clock.

#include <algorithm>
#include <atomic>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <utility>

#include <fmt/format.h>

#include "dco/core/error.hpp"
#include "dco/drivers/usb_capture.hpp"

namespace dco::drivers {
namespace {

using Kind = UsbCaptureRecord::Kind;
using Outcome = UsbCaptureRecord::Outcome;

// A driver that holds back the call the capture has next for this long (virtual time) has left
// the recording.
constexpr std::int64_t kCallPatienceNs = 30'000'000'000;
// handle_events() calls without progress before virtual time moves on regardless.
constexpr int kIdleCallsBeforeTimePasses = 64;
// Completions read ahead to find the call they arrived in. Inside one call (a control transfer's
// 200 ms, a stop) the fastest mode brings about 10 MB; more is a damaged capture, not one to load
// whole.
constexpr std::size_t kMostLookaheadBytes = 32u << 20;

bool is_completion(Kind k) {
  return k == Kind::kTransfer || k == Kind::kHotplug;
}

// A completion that arrived inside a call still running: that call's record comes after it.
bool inside_next_call(const UsbCaptureRecord& r) {
  return is_completion(r.kind) && (r.flags & UsbCaptureRecord::kInNextCall);
}

struct Stream {
  TransferCallback callback;
  int transfers = 0;
};

// Everything the transport and its devices share. Calls come from the driver's event thread (or
// before it starts); only the clock and the end state are read from other threads.
struct Replay {
  explicit Replay(const std::string& file) : path(file), reader(file) {}

  std::string path;
  UsbCaptureReader reader;
  std::deque<UsbCaptureRecord> window;  // records read ahead, the next one first
  std::size_t window_bytes = 0;         // their data
  std::size_t pos = 0;                  // records consumed
  std::atomic<std::int64_t> now{0};
  std::atomic<bool> finished{false};
  mutable std::mutex error_mutex;
  std::string error;
  std::optional<std::vector<UsbDeviceInfo>> latest_list;
  std::map<std::pair<std::uint16_t, std::uint8_t>, Stream> streams;
  std::function<void()> hotplug;
  int idle_calls = 0;

  // Whether record pos + i exists, reading ahead as far as needed.
  bool has(std::size_t i) {
    while (window.size() <= i) {
      if (window_bytes > kMostLookaheadBytes) {
        end(
            fmt::format("capture '{}' is damaged: more than {} MiB of completions after record {} "
                        "arrived inside one call",
                        path, kMostLookaheadBytes >> 20, pos));
        return false;
      }
      std::optional<UsbCaptureRecord> r = reader.next();
      if (!r) return false;
      window_bytes += r->data.size();
      window.push_back(std::move(*r));
    }
    return true;
  }
  bool at_end() { return !has(0); }
  const UsbCaptureRecord& next() { return window.front(); }

  // Consumes the next record and returns it.
  UsbCaptureRecord advance() {
    UsbCaptureRecord r = std::move(window.front());
    window.pop_front();
    window_bytes -= r.data.size();
    ++pos;
    idle_calls = 0;
    if (at_end())
      end(reader.problem().empty() ? std::string() : "capture '" + path + "': " + reader.problem());
    return r;
  }

  void end(std::string why) {
    {
      std::lock_guard lock(error_mutex);
      if (error.empty()) error = std::move(why);
    }
    finished = true;
  }

  [[noreturn]] void diverge(const std::string& what) {
    const std::string message =
        fmt::format("USB replay of '{}' left the capture at record {}: {}", path, pos, what);
    end(message);
    throw UsbError(message, false);
  }

  // The next call's record, past the completions that arrived inside that call; null when the
  // capture ends first.
  const UsbCaptureRecord* next_call() {
    for (std::size_t i = 0; has(i); ++i)
      if (!inside_next_call(window[i])) return &window[i];
    return nullptr;
  }

  std::string describe_next() {
    const UsbCaptureRecord* r = next_call();
    if (!r) return reader.problem().empty() ? "its end" : "its end (" + reader.problem() + ")";
    return fmt::format("{} (device {})", to_string(r->kind), r->device);
  }

  // What is left is the recorded driver shutting down (its streams stopped when it was told to
  // stop, a call that never returned before the recording ended): the replay has reached its end.
  bool only_shutdown_left() {
    for (std::size_t i = 0; has(i); ++i) {
      const UsbCaptureRecord& r = window[i];
      if (r.kind != Kind::kStopStreams && r.kind != Kind::kList &&
          !(r.flags & (UsbCaptureRecord::kInCall | UsbCaptureRecord::kInNextCall)))
        return false;
    }
    return true;
  }

  // Lists have no side effects: the ones a driver did not repeat are passed over.
  void skip_lists() {
    while (!at_end() && next().kind == Kind::kList) {
      latest_list = next().devices;
      advance();
    }
  }

  // The record for a call the driver makes now; throws when the capture has something else next.
  const UsbCaptureRecord& expect(Kind kind, std::uint16_t device) {
    if (finished) {
      std::lock_guard lock(error_mutex);
      throw UsbError(fmt::format("USB replay of '{}' has ended{}", path,
                                 error.empty() ? std::string() : ": " + error),
                     true);
    }
    skip_lists();
    const UsbCaptureRecord* r = next_call();
    if (!r || r->kind != kind || r->device != device)
      diverge(fmt::format("the capture has {} next, the driver called {} (device {})",
                          describe_next(), to_string(kind), device));
    return *r;
  }

  // Delivers what arrived inside the call the driver is making, at the times it arrived (the
  // driver reads its clock there), then consumes the call's record and replays its outcome.
  void conclude() {
    while (inside_next_call(next())) deliver_in_call(advance());
    const UsbCaptureRecord r = advance();
    // The recorded driver read its clock after the call had returned: a control transfer that
    // took 200 ms, or a busy module's retries, moved it on as much.
    now = std::max<std::int64_t>(now, r.t_ns);
    if (r.outcome != Outcome::kOk) throw UsbError(r.message, r.outcome == Outcome::kNoDevice);
  }

  void deliver_in_call(const UsbCaptureRecord& c) {
    now = std::max<std::int64_t>(now, c.t_ns);
    deliver(c);
  }

  void deliver(const UsbCaptureRecord& r) {
    if (r.kind == Kind::kHotplug) {
      if (hotplug) hotplug();
      return;
    }
    auto it = streams.find({r.device, r.endpoint});
    if (it == streams.end())
      diverge(fmt::format("a transfer on endpoint {:#04x} of device {} whose stream is not running",
                          r.endpoint, r.device));
    // The callback may not outlive its stream: copy it, the stream may end below.
    TransferCallback callback = it->second.callback;
    if (r.status == TransferStatus::kNoDevice || r.status == TransferStatus::kStall) {
      if (--it->second.transfers <= 0) streams.erase(it);
    }
    callback(r.status, r.data);
  }
};

class ReplayDevice final : public UsbDevice {
 public:
  ReplayDevice(std::shared_ptr<Replay> replay, std::uint16_t id, UsbDeviceInfo info)
      : r_(std::move(replay)), id_(id), info_(std::move(info)) {}

  const UsbDeviceInfo& info() const override { return info_; }

  void claim_interface(int number) override {
    const UsbCaptureRecord& r = r_->expect(Kind::kClaim, id_);
    if (r.interface != number)
      r_->diverge(
          fmt::format("the capture claims interface {}, the driver {}", r.interface, number));
    r_->conclude();
  }

  std::size_t control(std::uint8_t request_type, std::uint8_t request, std::uint16_t value,
                      std::uint16_t index, std::span<std::uint8_t> data,
                      std::chrono::milliseconds) override {
    const UsbCaptureRecord& r = r_->expect(Kind::kControl, id_);
    const bool in = request_type & 0x80;
    if (r.request_type != request_type || r.request != request || r.value != value ||
        r.index != index || r.length != data.size())
      r_->diverge(fmt::format(
          "the capture has control {:#04x} {:#04x} {:#06x} {:#06x} of {} bytes, the driver "
          "asked for {:#04x} {:#04x} {:#06x} {:#06x} of {} bytes",
          r.request_type, r.request, r.value, r.index, r.length, request_type, request, value,
          index, data.size()));
    if (!in && r.outcome == Outcome::kOk &&
        (r.data.size() != data.size() || !std::equal(data.begin(), data.end(), r.data.begin())))
      r_->diverge(
          fmt::format("the driver sent other bytes in control {:#04x} {:#06x} than the "
                      "capture has",
                      request, value));
    const std::size_t n = r.data.size();
    if (in) std::copy(r.data.begin(), r.data.end(), data.begin());
    r_->conclude();
    return n;
  }

  void clear_halt(std::uint8_t endpoint) override {
    const UsbCaptureRecord& r = r_->expect(Kind::kClearHalt, id_);
    if (r.endpoint != endpoint)
      r_->diverge(fmt::format("the capture clears endpoint {:#04x}, the driver {:#04x}", r.endpoint,
                              endpoint));
    r_->conclude();
  }

  void start_in_stream(std::uint8_t endpoint, EndpointType type, std::size_t transfer_size,
                       int transfers, TransferCallback on_complete) override {
    const UsbCaptureRecord& r = r_->expect(Kind::kStartStream, id_);
    if (r.endpoint != endpoint || r.type != type || r.size != transfer_size ||
        r.transfers != static_cast<std::uint32_t>(transfers))
      r_->diverge(fmt::format(
          "the capture streams endpoint {:#04x} with {} transfers of {} bytes, the driver "
          "endpoint {:#04x} with {} of {}",
          r.endpoint, r.transfers, r.size, endpoint, transfers, transfer_size));
    if (r.outcome == Outcome::kOk)
      r_->streams[{id_, endpoint}] = {std::move(on_complete), transfers};
    r_->conclude();
  }

  void stop_streams() override {
    if (!r_->finished) {
      try {
        r_->expect(Kind::kStopStreams, id_);
        r_->conclude();
        // Completions that arrived while the recorded stop_streams() waited for its transfers
        // reached the driver inside the call: so they do here.
        while (!r_->at_end() && (r_->next().flags & UsbCaptureRecord::kInCall))
          r_->deliver_in_call(r_->advance());
      } catch (const UsbError&) {
        // Never throws: the replay has ended and finish_error() says why.
      }
    }
    end_streams();
  }

  int transfers_in_flight() const override {
    int n = 0;
    for (const auto& [key, s] : r_->streams)
      if (key.first == id_) n += s.transfers;
    return n;
  }

 private:
  void end_streams() {
    for (auto it = r_->streams.begin(); it != r_->streams.end();)
      it = it->first.first == id_ ? r_->streams.erase(it) : std::next(it);
  }

  std::shared_ptr<Replay> r_;
  std::uint16_t id_;
  UsbDeviceInfo info_;
};

class ReplayTransport final : public UsbReplayTransport {
 public:
  explicit ReplayTransport(std::shared_ptr<Replay> replay) : r_(std::move(replay)) {
    r_->now = r_->next().t_ns;
  }

  std::vector<UsbDeviceInfo> list(std::uint16_t vendor, std::uint16_t product) override {
    Replay& r = *r_;
    if (!r.at_end() && r.next().kind == Kind::kList) {
      if (r.next().vendor != vendor || r.next().product != product)
        r.diverge(fmt::format("the capture lists {:04x}:{:04x}, the driver {:04x}:{:04x}",
                              r.next().vendor, r.next().product, vendor, product));
      r.latest_list = r.next().devices;
      r.now = std::max<std::int64_t>(r.now, r.next().t_ns);  // as after any call it answers
      r.advance();
    } else if (!r.latest_list) {
      r.diverge("the driver lists devices before the capture does");
    }
    return *r.latest_list;
  }

  std::unique_ptr<UsbDevice> open(const UsbDeviceInfo& device) override {
    Replay& r = *r_;
    r.skip_lists();
    const UsbCaptureRecord* call = r.next_call();
    if (!call || call->kind != Kind::kOpen)
      r.diverge(fmt::format("the capture has {} next, the driver opened {}", r.describe_next(),
                            device.port_path));
    const UsbCaptureRecord& rec = *call;
    if (rec.port_path != device.port_path)
      r.diverge(
          fmt::format("the capture opens '{}', the driver '{}'", rec.port_path, device.port_path));
    const std::uint16_t id = rec.device;
    r.conclude();
    return std::make_unique<ReplayDevice>(r_, id, device);
  }

  void watch_hotplug(std::uint16_t, std::uint16_t, std::function<void()> on_change) override {
    r_->hotplug = std::move(on_change);
  }

  void handle_events(std::chrono::milliseconds timeout) override {
    Replay& r = *r_;
    if (r.finished) return;
    const std::int64_t deadline = r.now + std::int64_t{timeout.count()} * 1'000'000;
    r.skip_lists();
    if (r.finished) return;
    if (r.only_shutdown_left()) {
      if (r.finished) return;  // damaged on the way
      while (!r.at_end()) r.advance();
      return;
    }
    const UsbCaptureRecord& rec = r.next();
    if (!is_completion(rec.kind) || inside_next_call(rec)) {
      // The driver makes the next call when its clock says so (one with completions inside it
      // started before the first of them); let time run up to it, and past it only when the
      // driver keeps polling without making it.
      if (rec.t_ns > r.now) {
        r.now = std::min(deadline, rec.t_ns);
      } else if (++r.idle_calls > kIdleCallsBeforeTimePasses) {
        r.now = deadline;
        if (r.now - rec.t_ns > kCallPatienceNs) {
          try {
            r.diverge(fmt::format("the driver did not call {} for {} s", r.describe_next(),
                                  kCallPatienceNs / 1'000'000'000));
          } catch (const UsbError&) {
          }
        }
      }
      return;
    }
    if (rec.flags & UsbCaptureRecord::kInCall)
      r.diverge(fmt::format("the capture has a completion inside a call the driver did not make"));
    if (rec.t_ns > deadline) {
      r.now = deadline;
      return;
    }
    // Everything that completed at one instant, as one batch, the way it was handled then.
    const std::int64_t t = rec.t_ns;
    r.now = std::max<std::int64_t>(r.now, t);
    while (!r.finished && is_completion(r.next().kind) && r.next().t_ns == t &&
           !(r.next().flags & (UsbCaptureRecord::kInCall | UsbCaptureRecord::kInNextCall)))
      r.deliver(r.advance());
  }

  bool finished() const override { return r_->finished; }
  std::string finish_error() const override {
    std::lock_guard lock(r_->error_mutex);
    return r_->error;
  }
  std::int64_t now_ns() const override { return r_->now; }

 private:
  std::shared_ptr<Replay> r_;
};

}  // namespace

std::unique_ptr<UsbReplayTransport> open_usb_replay(const std::string& path) {
  auto replay = std::make_shared<Replay>(path);
  if (replay->at_end())
    throw Error(
        fmt::format("USB capture '{}' holds no records{}", path,
                    replay->reader.problem().empty() ? "" : ": " + replay->reader.problem()));
  return std::make_unique<ReplayTransport>(std::move(replay));
}

}  // namespace dco::drivers
