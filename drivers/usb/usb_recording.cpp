// A transport that passes every call through to another one and writes it, with its outcome and
// every transfer completion, to a capture file.

#include <sys/stat.h>
#include <sys/statvfs.h>
#include <time.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <thread>
#include <utility>

#include <fmt/format.h>

#include "dco/core/error.hpp"
#include "dco/core/special_file.hpp"
#include "dco/drivers/usb_capture.hpp"

namespace dco::drivers {
namespace {

using Kind = UsbCaptureRecord::Kind;
using Outcome = UsbCaptureRecord::Outcome;

std::int64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

// A capture already at the path is a restarted service's last session, often the fault it was
// recording: one that streamed (past kKeptCaptureBytes) moves to PATH.1, replacing an older one,
// before the new capture is created. Smaller ones (a module not found, each restart of a service
// waiting for it) are written over, so they never push the one that matters out.
void keep_earlier_capture(const std::string& path) {
  struct stat st {};
  if (stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode) ||
      static_cast<std::uint64_t>(st.st_size) <= kKeptCaptureBytes)
    return;
  const std::string kept = path + ".1";
  if (std::rename(path.c_str(), kept.c_str()) != 0)
    throw Error(fmt::format("USB capture '{}': cannot keep the earlier capture as '{}': {}", path,
                            kept, std::strerror(errno)));
}

class CaptureWriter {
 public:
  CaptureWriter(const std::string& path, std::function<std::int64_t()> clock,
                std::uint64_t max_bytes)
      : path_(path), clock_(clock ? std::move(clock) : monotonic_ns), max_bytes_(max_bytes) {
    if (is_special_file(path))
      throw Error(
          fmt::format("USB capture '{}': not a file to record into (a directory, a device "
                      "or a pipe)",
                      path));
    keep_earlier_capture(path);
    file_ = std::fopen(path.c_str(), "wb");
    if (!file_)
      throw Error(fmt::format("USB capture '{}': cannot create: {}", path, std::strerror(errno)));
    if (std::fwrite(kUsbCaptureMagic, sizeof kUsbCaptureMagic, 1, file_) != 1) fail();
    written_ = sizeof kUsbCaptureMagic;
    stop_if_disk_low();
  }
  ~CaptureWriter() {
    if (file_ && std::fclose(file_) != 0)
      std::fprintf(stderr, "dco: USB capture '%s': closing failed: %s\n", path_.c_str(),
                   std::strerror(errno));
  }

  // Stamps and writes one record.
  void write(UsbCaptureRecord& r) {
    std::lock_guard lock(mutex_);
    write_locked(r);
  }

  // Writes a transfer completion or hotplug note, flagged when it arrived inside a call.
  void write_completion(UsbCaptureRecord& r) {
    std::lock_guard lock(mutex_);
    r.flags = call_thread_ == std::this_thread::get_id() ? call_flag_ : 0;
    write_locked(r);
  }

  // While it lives, completions this thread writes arrived inside a call (libusb handles events,
  // hotplug callbacks among them, inside its synchronous transfers) and carry `flag`: a replay
  // then delivers them inside the same call, where the driver saw them.
  class Call {
   public:
    Call(CaptureWriter& w, std::uint8_t flag) : w_(w) {
      std::lock_guard lock(w_.mutex_);
      outer_thread_ = w_.call_thread_;
      outer_flag_ = w_.call_flag_;
      w_.call_thread_ = std::this_thread::get_id();
      w_.call_flag_ = flag;
    }
    ~Call() {
      std::lock_guard lock(w_.mutex_);
      w_.call_thread_ = outer_thread_;
      w_.call_flag_ = outer_flag_;
    }
    Call(const Call&) = delete;
    Call& operator=(const Call&) = delete;

   private:
    CaptureWriter& w_;
    std::thread::id outer_thread_;
    std::uint8_t outer_flag_ = 0;
  };

 private:
  void write_locked(UsbCaptureRecord& r) {
    if (!file_) return;
    r.t_ns = clock_();
    buffer_.clear();
    encode_usb_capture_record(r, buffer_);
    if (written_ + buffer_.size() > max_bytes_) {
      stop(fmt::format("it reached its limit of {} MiB (record_max_mb)", max_bytes_ >> 20));
      return;
    }
    if (std::fwrite(buffer_.data(), buffer_.size(), 1, file_) != 1) {
      fail();
      return;
    }
    written_ += buffer_.size();
    if (written_ >= next_disk_check_) stop_if_disk_low();
  }

  // Looked at every kDiskCheckBytes written: statvfs is a system call.
  void stop_if_disk_low() {
    next_disk_check_ = written_ + kDiskCheckBytes;
    struct statvfs fs {};
    if (file_ && fstatvfs(fileno(file_), &fs) == 0 &&
        std::uint64_t{fs.f_bavail} * fs.f_frsize < kCaptureFreeBytes)
      stop(fmt::format("its file system has less than {} MiB free", kCaptureFreeBytes >> 20));
  }

  void fail() { stop(fmt::format("write failed ({})", std::strerror(errno))); }

  void stop(const std::string& why) {
    std::fprintf(stderr, "dco: USB capture '%s': %s; recording stopped, the camera runs on\n",
                 path_.c_str(), why.c_str());
    std::fclose(file_);
    file_ = nullptr;
  }

  static constexpr std::uint64_t kDiskCheckBytes = std::uint64_t{64} << 20;

  std::string path_;
  std::function<std::int64_t()> clock_;
  const std::uint64_t max_bytes_;
  std::uint64_t written_ = 0, next_disk_check_ = 0;
  std::mutex mutex_;
  std::FILE* file_ = nullptr;
  std::vector<std::uint8_t> buffer_;
  std::thread::id call_thread_;  // the thread inside a call; none when no call runs
  std::uint8_t call_flag_ = 0;
};

// Runs `call`, notes its outcome in `r`, writes `r` and passes on what the call threw. The record
// is written once the call returns, so completions that arrived inside it come before it, flagged
// kInNextCall.
template <typename F>
auto recorded(CaptureWriter& w, UsbCaptureRecord& r, F&& call) {
  auto inside = [&] {
    CaptureWriter::Call in_call(w, UsbCaptureRecord::kInNextCall);
    return call();
  };
  try {
    if constexpr (std::is_void_v<decltype(call())>) {
      inside();
      w.write(r);
    } else {
      auto result = inside();
      w.write(r);
      return result;
    }
  } catch (const UsbError& e) {
    r.outcome = e.no_device() ? Outcome::kNoDevice : Outcome::kFailed;
    r.message = e.what();
    r.data.clear();  // a failed transfer moved no bytes
    w.write(r);
    throw;
  }
}

class RecordingDevice final : public UsbDevice {
 public:
  RecordingDevice(std::unique_ptr<UsbDevice> inner, std::shared_ptr<CaptureWriter> writer,
                  std::uint16_t id)
      : inner_(std::move(inner)), writer_(std::move(writer)), id_(id) {}

  const UsbDeviceInfo& info() const override { return inner_->info(); }

  void claim_interface(int number) override {
    UsbCaptureRecord r = make(Kind::kClaim);
    r.interface = number;
    recorded(*writer_, r, [&] { inner_->claim_interface(number); });
  }

  std::size_t control(std::uint8_t request_type, std::uint8_t request, std::uint16_t value,
                      std::uint16_t index, std::span<std::uint8_t> data,
                      std::chrono::milliseconds timeout) override {
    UsbCaptureRecord r = make(Kind::kControl);
    r.request_type = request_type;
    r.request = request;
    r.value = value;
    r.index = index;
    r.length = static_cast<std::uint32_t>(data.size());
    const bool in = request_type & 0x80;
    if (!in) r.data.assign(data.begin(), data.end());
    return recorded(*writer_, r, [&] {
      const std::size_t n = inner_->control(request_type, request, value, index, data, timeout);
      if (in) r.data.assign(data.begin(), data.begin() + static_cast<std::ptrdiff_t>(n));
      return n;
    });
  }

  void clear_halt(std::uint8_t endpoint) override {
    UsbCaptureRecord r = make(Kind::kClearHalt);
    r.endpoint = endpoint;
    recorded(*writer_, r, [&] { inner_->clear_halt(endpoint); });
  }

  void start_in_stream(std::uint8_t endpoint, EndpointType type, std::size_t transfer_size,
                       int transfers, TransferCallback on_complete) override {
    UsbCaptureRecord r = make(Kind::kStartStream);
    r.endpoint = endpoint;
    r.type = type;
    r.size = static_cast<std::uint32_t>(transfer_size);
    r.transfers = static_cast<std::uint32_t>(transfers);
    auto wrapped = [this, endpoint, cb = std::move(on_complete)](
                       TransferStatus status, std::span<const std::uint8_t> data) {
      // Cancellations are what stop_streams() does; a replay reproduces them by itself.
      if (status != TransferStatus::kCancelled) {
        // One record serves every completion: its buffer stops growing after the first.
        transfer_.endpoint = endpoint;
        transfer_.status = status;
        transfer_.data.assign(data.begin(), data.end());
        writer_->write_completion(transfer_);
      }
      cb(status, data);
    };
    recorded(*writer_, r, [&] {
      inner_->start_in_stream(endpoint, type, transfer_size, transfers, std::move(wrapped));
    });
  }

  void stop_streams() override {
    UsbCaptureRecord r = make(Kind::kStopStreams);
    writer_->write(r);
    // Written before the call: what completes while it waits for its transfers follows it.
    CaptureWriter::Call in_call(*writer_, UsbCaptureRecord::kInCall);
    inner_->stop_streams();
  }

  int transfers_in_flight() const override { return inner_->transfers_in_flight(); }

 private:
  UsbCaptureRecord make(Kind kind) const {
    UsbCaptureRecord r;
    r.kind = kind;
    r.device = id_;
    return r;
  }

  std::unique_ptr<UsbDevice> inner_;
  std::shared_ptr<CaptureWriter> writer_;
  std::uint16_t id_;
  // Event thread only, like every call here.
  UsbCaptureRecord transfer_ = make(Kind::kTransfer);
};

class RecordingTransport final : public UsbTransport {
 public:
  RecordingTransport(std::unique_ptr<UsbTransport> inner, const std::string& path,
                     std::function<std::int64_t()> clock, std::uint64_t max_bytes)
      : inner_(std::move(inner)),
        writer_(std::make_shared<CaptureWriter>(path, std::move(clock), max_bytes)) {}

  // Listing handles no events: nothing can arrive inside it.
  std::vector<UsbDeviceInfo> list(std::uint16_t vendor, std::uint16_t product) override {
    UsbCaptureRecord r;
    r.kind = Kind::kList;
    r.vendor = vendor;
    r.product = product;
    r.devices = inner_->list(vendor, product);
    writer_->write(r);
    return r.devices;
  }

  std::unique_ptr<UsbDevice> open(const UsbDeviceInfo& device) override {
    UsbCaptureRecord r;
    r.kind = Kind::kOpen;
    r.port_path = device.port_path;
    r.device = next_id_;
    auto inner = recorded(*writer_, r, [&] { return inner_->open(device); });
    return std::make_unique<RecordingDevice>(std::move(inner), writer_, next_id_++);
  }

  void watch_hotplug(std::uint16_t vendor, std::uint16_t product,
                     std::function<void()> on_change) override {
    inner_->watch_hotplug(vendor, product, [w = writer_, cb = std::move(on_change)] {
      UsbCaptureRecord r;
      r.kind = Kind::kHotplug;
      w->write_completion(r);
      cb();
    });
  }

  void handle_events(std::chrono::milliseconds timeout) override { inner_->handle_events(timeout); }

 private:
  std::unique_ptr<UsbTransport> inner_;
  std::shared_ptr<CaptureWriter> writer_;
  std::uint16_t next_id_ = 0;
};

}  // namespace

std::unique_ptr<UsbTransport> make_recording_transport(std::unique_ptr<UsbTransport> inner,
                                                       const std::string& path,
                                                       std::function<std::int64_t()> clock,
                                                       std::uint64_t max_bytes) {
  return std::make_unique<RecordingTransport>(std::move(inner), path, std::move(clock), max_bytes);
}

}  // namespace dco::drivers
