#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "dco/core/error.hpp"

namespace dco::drivers {

// The seam between a USB camera driver and the bus. The real implementation sits on libusb; tests
// drive the same driver through generated and recorded byte streams with injected faults.
//
// Threading: a driver owns one event thread. It calls handle_events() in a loop, and it makes every
// other call on a UsbDevice from that thread too, so transfer callbacks, hotplug notes and device
// I/O never race. list() and open() may also be called before that thread starts.

enum class TransferStatus {
  kCompleted,  // data (possibly shorter than asked: a short packet)
  kTimedOut,
  kStall,     // the endpoint halted; clear_halt() before it streams again
  kNoDevice,  // the device went away; the transfer is not resubmitted
  kOverflow,  // the device sent more than the transfer holds
  kCancelled,
  kError,
};
const char* to_string(TransferStatus status);

enum class EndpointType { kBulk, kInterrupt };

struct UsbDeviceInfo {
  int bus = 0;
  int address = 0;
  std::string port_path;  // "bus-port.port...", stable across replug into the same socket
  int speed_mbps = 0;     // 12, 480, 5000, 10000; 0 when unknown
  std::string serial;     // iSerialNumber; empty when the device has none or it is unreadable
};

// A failed USB operation. `no_device` tells a vanished device from other failures.
class UsbError : public Error {
 public:
  UsbError(const std::string& what, bool no_device) : Error(what), no_device_(no_device) {}
  bool no_device() const { return no_device_; }

 private:
  bool no_device_;
};

// Completion of one asynchronous IN transfer. The bytes are valid during the call only.
using TransferCallback =
    std::function<void(TransferStatus status, std::span<const std::uint8_t> data)>;

// An opened device.
class UsbDevice {
 public:
  virtual ~UsbDevice() = default;
  virtual const UsbDeviceInfo& info() const = 0;

  // Claims an interface, detaching a kernel driver (uvcvideo, usbhid) first. Throws UsbError.
  virtual void claim_interface(int number) = 0;

  // A synchronous control transfer. The direction comes from bit 7 of request_type; `data` is the
  // payload to send or the buffer to fill. Returns the bytes transferred. Throws UsbError.
  virtual std::size_t control(std::uint8_t request_type, std::uint8_t request, std::uint16_t value,
                              std::uint16_t index, std::span<std::uint8_t> data,
                              std::chrono::milliseconds timeout) = 0;

  // Clears a halted endpoint. Throws UsbError.
  virtual void clear_halt(std::uint8_t endpoint) = 0;

  // Puts `transfers` asynchronous reads of `transfer_size` bytes in flight on an IN endpoint, with
  // buffers allocated here, once. Each completion calls `on_complete` (from handle_events) and
  // resubmits the transfer, except after kNoDevice, kCancelled and kStall (a halted endpoint
  // would fail every resubmission at once; the driver clears it and restarts the stream) or when
  // resubmission fails (reported as kNoDevice or kError). Throws UsbError when the first
  // submission fails.
  virtual void start_in_stream(std::uint8_t endpoint, EndpointType type, std::size_t transfer_size,
                               int transfers, TransferCallback on_complete) = 0;

  // Cancels every transfer of every stream and handles events until none is in flight; no
  // callback runs after it returns. Safe to call when the device is gone.
  virtual void stop_streams() = 0;

  // Transfers submitted and not yet completed, over all streams (for leak checks).
  virtual int transfers_in_flight() const = 0;
};

class UsbTransport {
 public:
  virtual ~UsbTransport() = default;

  // Devices with this vendor and product id that are attached now.
  virtual std::vector<UsbDeviceInfo> list(std::uint16_t vendor, std::uint16_t product) = 0;

  // Opens a device list() returned. Throws UsbError (gone, no permission: the message says which).
  virtual std::unique_ptr<UsbDevice> open(const UsbDeviceInfo& device) = 0;

  // `on_change` runs inside handle_events() when a matching device arrives or leaves. It may only
  // take note: no device I/O there (libusb forbids it). One watch per transport; a new call
  // replaces the old one. Transports without hotplug support poll list() instead.
  virtual void watch_hotplug(std::uint16_t vendor, std::uint16_t product,
                             std::function<void()> on_change) = 0;

  // Runs transfer completions and hotplug notes for at most `timeout`.
  virtual void handle_events(std::chrono::milliseconds timeout) = 0;

  // A recorded stream that has played to its end, or left the recording: the driver ends its
  // source, with finish_error() (empty at a clean end). A live bus never finishes.
  virtual bool finished() const { return false; }
  virtual std::string finish_error() const { return {}; }
};

// libusb. Throws UsbError when libusb cannot start (no usbfs in a container, for example).
std::unique_ptr<UsbTransport> make_libusb_transport();

}  // namespace dco::drivers
