// UsbTransport on libusb. Each transport has its own libusb context, shared with the devices it
// opens, so libusb_exit runs after the last of them is closed whichever is destroyed first.

#include <libusb.h>
#include <sys/time.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <climits>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "dco/drivers/usb_transport.hpp"

namespace dco::drivers {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

// A streaming transfer that sees no data for this long completes as kTimedOut, so a silent or
// halted endpoint reaches the callback instead of hanging the stream unnoticed.
constexpr unsigned kStreamTimeoutMs = 1000;
// stop_streams() waits this long for cancelled transfers. Linux completes cancellations at once,
// gone devices included; the transfer timeout above bounds even a cancellation that failed.
constexpr auto kCancelWait = std::chrono::seconds(2);
constexpr auto kPollInterval = milliseconds(500);

std::string usb_error(int code) {
  return fmt::format("{} ({})", libusb_error_name(code), libusb_strerror(code));
}

timeval to_timeval(milliseconds timeout) {
  const auto ms = std::max<std::int64_t>(timeout.count(), 0);
  timeval tv{};
  tv.tv_sec = static_cast<time_t>(ms / 1000);
  tv.tv_usec = static_cast<suseconds_t>(ms % 1000 * 1000);
  return tv;
}

int speed_mbps(int speed) {
  switch (speed) {
    case LIBUSB_SPEED_LOW:
      return 1;  // 1.5 Mb/s, rounded down so bandwidth is never overstated
    case LIBUSB_SPEED_FULL:
      return 12;
    case LIBUSB_SPEED_HIGH:
      return 480;
    case LIBUSB_SPEED_SUPER:
      return 5000;
    case LIBUSB_SPEED_SUPER_PLUS:
      return 10000;
#if LIBUSB_API_VERSION >= 0x0100010A
    case LIBUSB_SPEED_SUPER_PLUS_X2:
      return 20000;
#endif
    default:
      return 0;
  }
}

// "bus-port.port...", as Linux names the device in sysfs; a root hub is "bus-0", as in the names
// of its interfaces there.
std::string port_path(libusb_device* dev) {
  std::uint8_t ports[8];  // USB allows at most 7 tiers below the root hub
  const int n = libusb_get_port_numbers(dev, ports, static_cast<int>(sizeof ports));
  std::string path = fmt::format("{}-", libusb_get_bus_number(dev));
  if (n <= 0) return path + "0";
  for (int i = 0; i < n; ++i) {
    if (i > 0) path += '.';
    path += std::to_string(ports[i]);
  }
  return path;
}

UsbDeviceInfo describe(libusb_device* dev) {
  UsbDeviceInfo info;
  info.bus = libusb_get_bus_number(dev);
  info.address = libusb_get_device_address(dev);
  info.port_path = port_path(dev);
  info.speed_mbps = speed_mbps(libusb_get_device_speed(dev));
  return info;
}

std::string device_name(const UsbDeviceInfo& info) {
  if (info.port_path.empty())
    return fmt::format("USB device at bus {} address {}", info.bus, info.address);
  return fmt::format("USB device {} (bus {} address {})", info.port_path, info.bus, info.address);
}

TransferStatus to_status(libusb_transfer_status status) {
  switch (status) {
    case LIBUSB_TRANSFER_COMPLETED:
      return TransferStatus::kCompleted;
    case LIBUSB_TRANSFER_TIMED_OUT:
      return TransferStatus::kTimedOut;
    case LIBUSB_TRANSFER_STALL:
      return TransferStatus::kStall;
    case LIBUSB_TRANSFER_NO_DEVICE:
      return TransferStatus::kNoDevice;
    case LIBUSB_TRANSFER_OVERFLOW:
      return TransferStatus::kOverflow;
    case LIBUSB_TRANSFER_CANCELLED:
      return TransferStatus::kCancelled;
    case LIBUSB_TRANSFER_ERROR:
      break;
  }
  return TransferStatus::kError;
}

// The libusb context and what its callbacks share with the calls that run them.
struct Context {
  Context() = default;
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
  ~Context() {
    if (usb != nullptr) libusb_exit(usb);
  }

  // Exceptions must not unwind through libusb's C frames: the first one a user callback throws
  // waits here and leaves through handle_events().
  void keep(std::exception_ptr e) {
    if (!pending) pending = std::move(e);
  }
  void rethrow_pending() {
    if (pending) std::rethrow_exception(std::exchange(pending, nullptr));
  }

  // libusb cannot handle events again from inside one of its callbacks: it would wait for the
  // event lock its own thread holds. Calls that need event handling check this first.
  void require_outside_callback(const char* call) const {
    if (callback_depth > 0)
      throw UsbError(fmt::format("{} called from a USB completion or hotplug callback", call),
                     false);
  }

  libusb_context* usb = nullptr;
  int callback_depth = 0;  // libusb callbacks now running on the event thread
  std::exception_ptr pending;
};

// Counts a libusb callback for require_outside_callback().
class InCallback {
 public:
  explicit InCallback(Context& ctx) : ctx_(ctx) { ++ctx_.callback_depth; }
  ~InCallback() { --ctx_.callback_depth; }
  InCallback(const InCallback&) = delete;
  InCallback& operator=(const InCallback&) = delete;

 private:
  Context& ctx_;
};

// libusb_get_device_list() with the references dropped on every path out.
class DeviceList {
 public:
  explicit DeviceList(libusb_context* usb) {
    const ssize_t n = libusb_get_device_list(usb, &devices_);
    if (n < 0)
      throw UsbError(fmt::format("cannot list USB devices: {}", usb_error(static_cast<int>(n))),
                     false);
    count_ = static_cast<std::size_t>(n);
  }
  ~DeviceList() {
    if (devices_ != nullptr) libusb_free_device_list(devices_, 1);
  }
  DeviceList(const DeviceList&) = delete;
  DeviceList& operator=(const DeviceList&) = delete;

  std::span<libusb_device* const> devices() const { return {devices_, count_}; }

 private:
  libusb_device** devices_ = nullptr;
  std::size_t count_ = 0;
};

bool matches(libusb_device* dev, std::uint16_t vendor, std::uint16_t product) {
  libusb_device_descriptor desc{};
  return libusb_get_device_descriptor(dev, &desc) == 0 && desc.idVendor == vendor &&
         desc.idProduct == product;
}

std::string read_serial(libusb_device* dev, std::uint8_t index) {
  libusb_device_handle* handle = nullptr;
  if (libusb_open(dev, &handle) != 0) return {};
  unsigned char text[256];
  const int n = libusb_get_string_descriptor_ascii(handle, index, text, sizeof text);
  libusb_close(handle);
  if (n <= 0) return {};
  return std::string(reinterpret_cast<const char*>(text), static_cast<std::size_t>(n));
}

std::vector<std::pair<int, int>> addresses(libusb_context* usb, std::uint16_t vendor,
                                           std::uint16_t product) {
  std::vector<std::pair<int, int>> out;
  DeviceList list(usb);
  for (libusb_device* dev : list.devices())
    if (matches(dev, vendor, product))
      out.emplace_back(libusb_get_bus_number(dev), libusb_get_device_address(dev));
  std::sort(out.begin(), out.end());
  return out;
}

class LibusbDevice;
struct Stream;

struct Slot {
  Stream* stream = nullptr;
  libusb_transfer* transfer = nullptr;
  std::unique_ptr<std::uint8_t[]> buffer;
  bool in_flight = false;
};

// One start_in_stream(): its transfers and their buffers, allocated once.
struct Stream {
  Stream() = default;
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;
  // Only once libusb holds none of the transfers: none in flight, or the handle closed.
  ~Stream() {
    for (Slot& slot : slots) libusb_free_transfer(slot.transfer);
  }

  LibusbDevice* device = nullptr;
  TransferCallback on_complete;
  std::vector<Slot> slots;  // sized once: each transfer points at its slot
  int in_flight = 0;
  int in_callback = 0;   // on_complete calls running now
  bool stopped = false;  // nothing is reported or resubmitted any more
};

class LibusbDevice final : public UsbDevice {
 public:
  LibusbDevice(std::shared_ptr<Context> ctx, libusb_device_handle* handle, UsbDeviceInfo info)
      : ctx_(std::move(ctx)), handle_(handle), info_(std::move(info)) {}

  ~LibusbDevice() override {
    stop_streams();
    for (int number : claimed_) libusb_release_interface(handle_, number);  // gone: nothing to do
    libusb_close(handle_);
    // Closing the usbfs file killed whatever outlived stop_streams() and libusb dropped it
    // without a callback, so these transfers are free to go.
    stopped_.clear();
  }

  LibusbDevice(const LibusbDevice&) = delete;
  LibusbDevice& operator=(const LibusbDevice&) = delete;

  const UsbDeviceInfo& info() const override { return info_; }

  void claim_interface(int number) override {
    const int r = libusb_claim_interface(handle_, number);
    if (r != 0) {
      const char* hint = "";
      if (r == LIBUSB_ERROR_BUSY)
        hint = "; another program or a kernel driver that could not be detached holds it";
      else if (r == LIBUSB_ERROR_NOT_FOUND)
        hint = "; the device has no such interface";
      throw UsbError(fmt::format("cannot claim interface {} of {}: {}{}", number,
                                 device_name(info_), usb_error(r), hint),
                     r == LIBUSB_ERROR_NO_DEVICE);
    }
    if (std::find(claimed_.begin(), claimed_.end(), number) == claimed_.end())
      claimed_.push_back(number);
  }

  std::size_t control(std::uint8_t request_type, std::uint8_t request, std::uint16_t value,
                      std::uint16_t index, std::span<std::uint8_t> data,
                      milliseconds timeout) override {
    // A synchronous transfer handles events to wait for its completion.
    ctx_->require_outside_callback("UsbDevice::control()");
    const auto describe_request = [&] {
      return fmt::format(
          "control transfer to {} (type 0x{:02x}, request 0x{:02x}, value 0x{:04x}, index "
          "0x{:04x}, {} bytes)",
          device_name(info_), request_type, request, value, index, data.size());
    };
    if (data.size() > 0xffff)
      throw UsbError(describe_request() + ": more than the 65535 bytes a control transfer holds",
                     false);
    // libusb reads 0 as "wait forever", which no caller here wants.
    const auto ms = std::clamp<std::int64_t>(timeout.count(), 1, UINT_MAX);
    const int r =
        libusb_control_transfer(handle_, request_type, request, value, index, data.data(),
                                static_cast<std::uint16_t>(data.size()), static_cast<unsigned>(ms));
    if (r < 0)
      throw UsbError(fmt::format("{} failed: {}", describe_request(), usb_error(r)),
                     r == LIBUSB_ERROR_NO_DEVICE);
    return static_cast<std::size_t>(r);
  }

  void clear_halt(std::uint8_t endpoint) override {
    const int r = libusb_clear_halt(handle_, endpoint);
    if (r != 0)
      throw UsbError(fmt::format("cannot clear the halt of endpoint 0x{:02x} of {}: {}", endpoint,
                                 device_name(info_), usb_error(r)),
                     r == LIBUSB_ERROR_NO_DEVICE);
  }

  void start_in_stream(std::uint8_t endpoint, EndpointType type, std::size_t transfer_size,
                       int transfers, TransferCallback on_complete) override {
    const auto fail = [&](const std::string& why, bool no_device) {
      return UsbError(fmt::format("cannot stream from endpoint 0x{:02x} of {} ({} x {} bytes): {}",
                                  endpoint, device_name(info_), transfers, transfer_size, why),
                      no_device);
    };
    if ((endpoint & LIBUSB_ENDPOINT_IN) == 0) throw fail("not an IN endpoint", false);
    if (transfer_size == 0 || transfer_size > INT_MAX || transfers < 1)
      throw fail("the transfer size or count is out of range", false);
    if (!on_complete) throw fail("no completion callback", false);

    auto stream = std::make_unique<Stream>();
    stream->device = this;
    stream->on_complete = std::move(on_complete);
    stream->slots.resize(static_cast<std::size_t>(transfers));
    for (Slot& slot : stream->slots) {
      slot.stream = stream.get();
      slot.buffer = std::make_unique_for_overwrite<std::uint8_t[]>(transfer_size);
      slot.transfer = libusb_alloc_transfer(0);
      if (slot.transfer == nullptr) throw fail("out of memory for transfers", false);
      const int length = static_cast<int>(transfer_size);
      if (type == EndpointType::kBulk)
        libusb_fill_bulk_transfer(slot.transfer, handle_, endpoint, slot.buffer.get(), length,
                                  &LibusbDevice::transfer_done, &slot, kStreamTimeoutMs);
      else
        libusb_fill_interrupt_transfer(slot.transfer, handle_, endpoint, slot.buffer.get(), length,
                                       &LibusbDevice::transfer_done, &slot, kStreamTimeoutMs);
    }

    Stream& started = *stream;
    streams_.push_back(std::move(stream));
    for (Slot& slot : started.slots) {
      const int r = submit(slot);
      if (r == 0) continue;
      // A failed start leaves nothing streaming: take back what already went out.
      stop(started);
      wait_for_stopped();
      std::string why = usb_error(r);
      if (r == LIBUSB_ERROR_NO_MEM)
        why +=
            "; the kernel's usbfs buffer limit (/sys/module/usbcore/parameters/usbfs_memory_mb)"
            " may be too low";
      throw fail(why, r == LIBUSB_ERROR_NO_DEVICE);
    }
  }

  void stop_streams() override {
    while (!streams_.empty()) stop(*streams_.back());
    wait_for_stopped();
  }

  int transfers_in_flight() const override { return in_flight_.load(std::memory_order_relaxed); }

 private:
  static void LIBUSB_CALL transfer_done(libusb_transfer* transfer) {
    Slot& slot = *static_cast<Slot*>(transfer->user_data);
    LibusbDevice& device = *slot.stream->device;
    InCallback in_callback(*device.ctx_);
    device.complete(slot);
  }

  int submit(Slot& slot) {
    const int r = libusb_submit_transfer(slot.transfer);
    if (r == 0) {
      slot.in_flight = true;
      ++slot.stream->in_flight;
      in_flight_.fetch_add(1, std::memory_order_relaxed);
    }
    return r;
  }

  void complete(Slot& slot) {
    Stream& stream = *slot.stream;
    slot.in_flight = false;
    --stream.in_flight;
    in_flight_.fetch_sub(1, std::memory_order_relaxed);

    const TransferStatus status = to_status(slot.transfer->status);
    const auto length = static_cast<std::size_t>(std::max(slot.transfer->actual_length, 0));
    report(stream, status, {slot.buffer.get(), length});
    // The callback may have stopped the streams. A halted endpoint fails every resubmission at
    // once: the transfer rests until the driver clears the halt and restarts the stream.
    if (!stream.stopped && status != TransferStatus::kNoDevice &&
        status != TransferStatus::kCancelled && status != TransferStatus::kStall) {
      const int r = submit(slot);
      if (r != 0)
        report(stream,
               r == LIBUSB_ERROR_NO_DEVICE ? TransferStatus::kNoDevice : TransferStatus::kError,
               {});
    }
    if (stream.stopped) release_stopped();  // may free `stream` and `slot`
  }

  void report(Stream& stream, TransferStatus status, std::span<const std::uint8_t> data) {
    if (stream.stopped) return;
    ++stream.in_callback;
    try {
      stream.on_complete(status, data);
    } catch (...) {
      ctx_->keep(std::current_exception());
    }
    --stream.in_callback;
  }

  // Moves a stream to stopped_ and cancels its transfers; their completions report nothing.
  void stop(Stream& stream) {
    stream.stopped = true;
    for (Slot& slot : stream.slots)
      if (slot.in_flight) libusb_cancel_transfer(slot.transfer);  // done already or gone: fine
    const auto it = std::find_if(streams_.begin(), streams_.end(),
                                 [&](const auto& s) { return s.get() == &stream; });
    stopped_.push_back(std::move(*it));
    streams_.erase(it);
  }

  void wait_for_stopped() {
    // Inside a libusb callback events cannot be handled; the cancelled transfers come back once
    // the event loop runs again, and are freed then.
    if (ctx_->callback_depth == 0) {
      const auto deadline = Clock::now() + kCancelWait;
      while (stopped_in_flight() > 0 && Clock::now() < deadline) {
        timeval tv = to_timeval(milliseconds(100));
        libusb_handle_events_timeout_completed(ctx_->usb, &tv, nullptr);
      }
    }
    release_stopped();
  }

  int stopped_in_flight() const {
    int n = 0;
    for (const auto& s : stopped_) n += s->in_flight;
    return n;
  }

  void release_stopped() {
    std::erase_if(stopped_, [](const auto& s) { return s->in_flight == 0 && s->in_callback == 0; });
  }

  std::shared_ptr<Context> ctx_;
  libusb_device_handle* handle_;
  UsbDeviceInfo info_;
  std::vector<int> claimed_;
  std::vector<std::unique_ptr<Stream>> streams_;
  std::vector<std::unique_ptr<Stream>> stopped_;  // waiting for their transfers to come back
  std::atomic<int> in_flight_{0};
};

class LibusbTransport final : public UsbTransport {
 public:
  explicit LibusbTransport(std::shared_ptr<Context> ctx) : ctx_(std::move(ctx)) {}
  ~LibusbTransport() override { unwatch(); }

  LibusbTransport(const LibusbTransport&) = delete;
  LibusbTransport& operator=(const LibusbTransport&) = delete;

  std::vector<UsbDeviceInfo> list(std::uint16_t vendor, std::uint16_t product) override {
    // Reading a serial number is a synchronous transfer.
    ctx_->require_outside_callback("UsbTransport::list()");
    std::vector<UsbDeviceInfo> out;
    DeviceList devices(ctx_->usb);
    for (libusb_device* dev : devices.devices()) {
      libusb_device_descriptor desc{};
      if (libusb_get_device_descriptor(dev, &desc) != 0 || desc.idVendor != vendor ||
          desc.idProduct != product)
        continue;
      UsbDeviceInfo info = describe(dev);
      if (desc.iSerialNumber != 0) info.serial = read_serial(dev, desc.iSerialNumber);
      out.push_back(std::move(info));
    }
    std::sort(out.begin(), out.end(), [](const UsbDeviceInfo& a, const UsbDeviceInfo& b) {
      return std::pair(a.bus, a.address) < std::pair(b.bus, b.address);
    });
    return out;
  }

  std::unique_ptr<UsbDevice> open(const UsbDeviceInfo& device) override {
    const std::string name = device_name(device);
    DeviceList devices(ctx_->usb);
    libusb_device* found = nullptr;
    for (libusb_device* dev : devices.devices()) {
      // A different port at the same address is a new device that reused the number.
      if (libusb_get_bus_number(dev) == device.bus &&
          libusb_get_device_address(dev) == device.address &&
          (device.port_path.empty() || port_path(dev) == device.port_path)) {
        found = dev;
        break;
      }
    }
    const auto gone = [&] {
      return UsbError(name + " is gone: it was unplugged or re-enumerated since it was listed",
                      true);
    };
    if (found == nullptr) throw gone();

    libusb_device_handle* raw = nullptr;
    const int r = libusb_open(found, &raw);
    if (r == LIBUSB_ERROR_NO_DEVICE || r == LIBUSB_ERROR_NOT_FOUND) throw gone();
    if (r == LIBUSB_ERROR_ACCESS) {
      libusb_device_descriptor desc{};
      libusb_get_device_descriptor(found, &desc);
      throw UsbError(
          fmt::format("no permission to open {} [{:04x}:{:04x}]: {}; the udev rule "
                      "60-dco-indemind.rules gives group 'dcod' access to 05a9:f581: install it, "
                      "replug the device and run as a member of group dcod",
                      name, desc.idVendor, desc.idProduct, usb_error(r)),
          false);
    }
    if (r != 0) throw UsbError(fmt::format("cannot open {}: {}", name, usb_error(r)), false);
    std::unique_ptr<libusb_device_handle, decltype(&libusb_close)> handle(raw, &libusb_close);

    // Lets claim_interface() take the interface from uvcvideo or usbhid, and give it back on
    // release. Not every platform supports it; claiming then reports the busy interface.
    libusb_set_auto_detach_kernel_driver(handle.get(), 1);

    UsbDeviceInfo info = describe(found);
    info.serial = device.serial;
    auto opened = std::make_unique<LibusbDevice>(ctx_, handle.get(), std::move(info));
    handle.release();
    return opened;
  }

  void watch_hotplug(std::uint16_t vendor, std::uint16_t product,
                     std::function<void()> on_change) override {
    unwatch();
    if (!on_change) return;
    on_change_ = std::move(on_change);
    if (libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG) != 0) {
      const int r = libusb_hotplug_register_callback(
          ctx_->usb, LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED | LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT,
          LIBUSB_HOTPLUG_NO_FLAGS, vendor, product, LIBUSB_HOTPLUG_MATCH_ANY,
          &LibusbTransport::hotplug_note, this, &hotplug_);
      if (r == 0) {
        registered_ = true;
        return;
      }
    }
    // No hotplug events: handle_events() compares the bus with this snapshot instead.
    polling_ = true;
    poll_vendor_ = vendor;
    poll_product_ = product;
    polled_ = addresses(ctx_->usb, vendor, product);
    next_poll_ = Clock::now() + kPollInterval;
  }

  void handle_events(milliseconds timeout) override {
    ctx_->require_outside_callback("UsbTransport::handle_events()");
    auto wait = std::max(timeout, milliseconds(0));
    if (polling_)
      wait = std::clamp(std::chrono::duration_cast<milliseconds>(next_poll_ - Clock::now()),
                        milliseconds(0), wait);
    timeval tv = to_timeval(wait);
    const int r = libusb_handle_events_timeout_completed(ctx_->usb, &tv, nullptr);
    if (polling_ && Clock::now() >= next_poll_) poll();
    ctx_->rethrow_pending();
    if (r < 0 && r != LIBUSB_ERROR_INTERRUPTED && r != LIBUSB_ERROR_TIMEOUT)
      throw UsbError(fmt::format("libusb event handling failed: {}", usb_error(r)), false);
  }

 private:
  static int LIBUSB_CALL hotplug_note(libusb_context*, libusb_device*, libusb_hotplug_event,
                                      void* user_data) {
    static_cast<LibusbTransport*>(user_data)->notify();
    return 0;  // stay registered
  }

  void notify() {
    InCallback in_callback(*ctx_);
    // A copy, so that a watch replaced from inside the note does not pull the function away
    // while it runs.
    const std::function<void()> on_change = on_change_;
    try {
      on_change();
    } catch (...) {
      ctx_->keep(std::current_exception());
    }
  }

  void poll() {
    next_poll_ = Clock::now() + kPollInterval;
    auto now = addresses(ctx_->usb, poll_vendor_, poll_product_);
    if (now == polled_) return;
    polled_ = std::move(now);
    notify();
  }

  void unwatch() {
    if (registered_) libusb_hotplug_deregister_callback(ctx_->usb, hotplug_);
    registered_ = false;
    polling_ = false;
    polled_.clear();
    on_change_ = nullptr;
  }

  std::shared_ptr<Context> ctx_;
  std::function<void()> on_change_;
  bool registered_ = false;
  libusb_hotplug_callback_handle hotplug_ = 0;
  bool polling_ = false;
  std::uint16_t poll_vendor_ = 0, poll_product_ = 0;
  std::vector<std::pair<int, int>> polled_;  // (bus, address), sorted
  Clock::time_point next_poll_{};
};

}  // namespace

std::unique_ptr<UsbTransport> make_libusb_transport() {
  auto ctx = std::make_shared<Context>();
  const int r = libusb_init(&ctx->usb);
  if (r != 0) {
    ctx->usb = nullptr;
    throw UsbError(
        fmt::format("cannot start libusb: {}; USB cameras need usbfs (/dev/bus/usb)", usb_error(r)),
        false);
  }
  return std::make_unique<LibusbTransport>(std::move(ctx));
}

}  // namespace dco::drivers
