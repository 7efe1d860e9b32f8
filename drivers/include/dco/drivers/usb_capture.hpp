#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "dco/drivers/usb_transport.hpp"

namespace dco::drivers {

// A capture of the traffic at the USB transport seam: every call a driver made on the bus, with
// its outcome, and every transfer completion, in order and with the driver's clock. A module that
// misbehaves in the field is recorded with `indemind://?record=FILE` and replayed on a desk with
// `indemind://?replay=FILE`, byte for byte and time for time.
//
// File: the 8 bytes "DCOUSBC1", then records, all little-endian. A record is a 16-byte head
// (u8 kind, u8 flags, u16 device, u32 body length, i64 time in ns) and its body. Strings are a
// u16 length and bytes. Calls end their body with an outcome byte (0 ok, 1 failed, 2 device
// gone) and, when it is not 0, the error message. A call is written when it returns, except
// stop_streams(), written when it starts. A transfer completion or hotplug note that arrived
// inside a call (libusb handles events inside synchronous transfers) is flagged, so a replay
// delivers it inside that call: kInNextCall before the call's record, kInCall after a stop's.
struct UsbCaptureRecord {
  enum class Kind : std::uint8_t {
    kList = 1,     // list(vendor, product) and the devices it returned
    kOpen,         // open(port_path)
    kClaim,        // claim_interface(interface)
    kControl,      // a control transfer: the request, the bytes sent or received
    kClearHalt,    // clear_halt(endpoint)
    kStartStream,  // start_in_stream(endpoint, type, size, transfers)
    kStopStreams,  // stop_streams()
    kTransfer,     // a completed transfer: endpoint, status, bytes
    kHotplug,      // the hotplug note
  };
  // Flags of completions delivered inside a device call: the stop_streams() recorded before it,
  // or the call whose record comes next (after any more flagged completions).
  static constexpr std::uint8_t kInCall = 1;
  static constexpr std::uint8_t kInNextCall = 2;

  Kind kind = Kind::kList;
  std::uint8_t flags = 0;
  std::uint16_t device = 0;  // which opened device (0, 1, ... in open order)
  std::int64_t t_ns = 0;

  enum class Outcome : std::uint8_t { kOk = 0, kFailed = 1, kNoDevice = 2 };
  Outcome outcome = Outcome::kOk;
  std::string message;

  std::uint16_t vendor = 0, product = 0;  // kList
  std::vector<UsbDeviceInfo> devices;     // kList
  std::string port_path;                  // kOpen
  int interface = 0;                      // kClaim
  std::uint8_t request_type = 0, request = 0;
  std::uint16_t value = 0, index = 0;
  std::uint32_t length = 0;  // kControl: bytes asked for or offered
  std::uint8_t endpoint = 0;
  EndpointType type = EndpointType::kBulk;
  std::uint32_t size = 0, transfers = 0;  // kStartStream
  TransferStatus status = TransferStatus::kCompleted;
  std::vector<std::uint8_t> data;  // kControl: the bytes moved; kTransfer: the bytes received
};

const char* to_string(UsbCaptureRecord::Kind kind);

inline constexpr char kUsbCaptureMagic[8] = {'D', 'C', 'O', 'U', 'S', 'B', 'C', '1'};

// Appends one record in the file format.
void encode_usb_capture_record(const UsbCaptureRecord& record, std::vector<std::uint8_t>& out);

struct UsbCapture {
  std::vector<UsbCaptureRecord> records;
  std::size_t bytes_read = 0;  // up to the end of the last whole record
  std::string problem;         // why reading stopped before the end; empty when it did not
};

// Reads a whole capture. A file that is not a capture throws dco::Error; a truncated or damaged
// one yields the records before the damage and says where it stopped.
UsbCapture parse_usb_capture(std::span<const std::uint8_t> bytes);

// Reads a capture file record by record, so a long one never has to fit in memory.
class UsbCaptureReader {
 public:
  // Throws dco::Error when the file cannot be opened or is not a capture.
  explicit UsbCaptureReader(const std::string& path);
  ~UsbCaptureReader();
  UsbCaptureReader(const UsbCaptureReader&) = delete;
  UsbCaptureReader& operator=(const UsbCaptureReader&) = delete;

  // The next record; nullopt at the end of the file or at damage, which problem() then names.
  std::optional<UsbCaptureRecord> next();
  const std::string& problem() const { return problem_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
  bool done_ = false;
  std::size_t index_ = 0, offset_ = 0;
  std::int64_t last_t_ns_ = 0;
  std::vector<std::uint8_t> body_;
  std::string problem_;
};

// Wraps a transport and writes everything that crosses it to `path`. `clock` stamps the records
// (CLOCK_MONOTONIC by default; it must be the driver's clock for a replay to reproduce it). A
// capture of more than kKeptCaptureBytes already at `path` is moved to `path`.1 first (a
// restarted service keeps the session that recorded its fault); smaller ones are written over.
// Throws dco::Error when the file cannot be created; a later write failure stops the recording
// with one line on stderr and leaves the camera running. So does a capture that would grow past
// `max_bytes`, or leave its file system with less than kCaptureFreeBytes: a capture runs at tens
// of megabytes a second and must not fill a headset's disk. It then ends after a whole record,
// and replays as far as it goes.
inline constexpr std::uint64_t kKeptCaptureBytes = 64 * 1024;
inline constexpr std::uint64_t kDefaultCaptureMaxBytes = std::uint64_t{4096} << 20;
inline constexpr std::uint64_t kCaptureFreeBytes = std::uint64_t{256} << 20;
std::unique_ptr<UsbTransport> make_recording_transport(
    std::unique_ptr<UsbTransport> inner, const std::string& path,
    std::function<std::int64_t()> clock = {}, std::uint64_t max_bytes = kDefaultCaptureMaxBytes);

// Plays a capture back as a transport. Time is the capture's: now_ns() is the time of the last
// event delivered or call answered, so a driver given it as its clock makes the decisions it made
// when recording.
// Every call must be the one the capture has next (list() excepted: it has no side effects and
// is answered with the latest listing); a call that differs ends the replay with an error that
// names both. finished() turns true after the last record.
class UsbReplayTransport : public UsbTransport {
 public:
  virtual std::int64_t now_ns() const = 0;
};

// Throws dco::Error when the file cannot be read or is not a capture.
std::unique_ptr<UsbReplayTransport> open_usb_replay(const std::string& path);

}  // namespace dco::drivers
