// The USB capture file format: one codec shared by the recorder, the replayer and the fuzz target.

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string>

#include "dco/core/error.hpp"
#include "dco/core/special_file.hpp"
#include "dco/drivers/usb_capture.hpp"

namespace dco::drivers {
namespace {

using Kind = UsbCaptureRecord::Kind;
using Outcome = UsbCaptureRecord::Outcome;

constexpr std::size_t kHeadBytes = 16;
// Larger than any transfer or control payload a driver asks for; a length beyond it is damage.
constexpr std::uint32_t kMaxBody = 64u << 20;
constexpr std::uint32_t kMaxDevices = 256;

void put(std::vector<std::uint8_t>& out, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

void put_string(std::vector<std::uint8_t>& out, const std::string& s) {
  const std::size_t n = std::min<std::size_t>(s.size(), 0xffff);
  put(out, n, 2);
  out.insert(out.end(), s.begin(), s.begin() + static_cast<std::ptrdiff_t>(n));
}

void put_bytes(std::vector<std::uint8_t>& out, const std::vector<std::uint8_t>& b) {
  put(out, b.size(), 4);
  out.insert(out.end(), b.begin(), b.end());
}

bool is_call(Kind k) {
  return k != Kind::kTransfer && k != Kind::kHotplug;
}

// Reads a body; every read is bounds-checked and a failure sticks.
class BodyReader {
 public:
  explicit BodyReader(std::span<const std::uint8_t> b) : b_(b) {}
  std::uint64_t u(int bytes) {
    if (!ok_ || b_.size() - pos_ < static_cast<std::size_t>(bytes)) {
      ok_ = false;
      return 0;
    }
    std::uint64_t v = 0;
    for (int i = 0; i < bytes; ++i) v |= std::uint64_t{b_[pos_ + i]} << (8 * i);
    pos_ += static_cast<std::size_t>(bytes);
    return v;
  }
  std::string string() {
    const std::size_t n = u(2);
    if (!ok_ || b_.size() - pos_ < n) {
      ok_ = false;
      return {};
    }
    std::string s(reinterpret_cast<const char*>(b_.data() + pos_), n);
    pos_ += n;
    return s;
  }
  std::vector<std::uint8_t> bytes() {
    const std::size_t n = u(4);
    if (!ok_ || b_.size() - pos_ < n) {
      ok_ = false;
      return {};
    }
    std::vector<std::uint8_t> v(b_.begin() + static_cast<std::ptrdiff_t>(pos_),
                                b_.begin() + static_cast<std::ptrdiff_t>(pos_ + n));
    pos_ += n;
    return v;
  }
  bool ok() const { return ok_; }
  bool at_end() const { return pos_ == b_.size(); }
  void fail() { ok_ = false; }

 private:
  std::span<const std::uint8_t> b_;
  std::size_t pos_ = 0;
  bool ok_ = true;
};

// Decodes a body into `r`; false when it does not hold what its kind needs.
bool decode_body(BodyReader& in, UsbCaptureRecord& r) {
  switch (r.kind) {
    case Kind::kList: {
      r.vendor = static_cast<std::uint16_t>(in.u(2));
      r.product = static_cast<std::uint16_t>(in.u(2));
      const std::uint64_t n = in.u(4);
      if (n > kMaxDevices) return false;
      for (std::uint64_t i = 0; i < n && in.ok(); ++i) {
        UsbDeviceInfo d;
        d.bus = static_cast<int>(in.u(2));
        d.address = static_cast<int>(in.u(2));
        d.speed_mbps = static_cast<int>(in.u(4));
        d.port_path = in.string();
        d.serial = in.string();
        r.devices.push_back(std::move(d));
      }
      break;
    }
    case Kind::kOpen:
      r.port_path = in.string();
      break;
    case Kind::kClaim:
      r.interface = static_cast<int>(in.u(1));
      break;
    case Kind::kControl:
      r.request_type = static_cast<std::uint8_t>(in.u(1));
      r.request = static_cast<std::uint8_t>(in.u(1));
      r.value = static_cast<std::uint16_t>(in.u(2));
      r.index = static_cast<std::uint16_t>(in.u(2));
      r.length = static_cast<std::uint32_t>(in.u(4));
      r.data = in.bytes();
      if (r.data.size() > r.length) return false;
      break;
    case Kind::kClearHalt:
      r.endpoint = static_cast<std::uint8_t>(in.u(1));
      break;
    case Kind::kStartStream: {
      r.endpoint = static_cast<std::uint8_t>(in.u(1));
      const std::uint64_t type = in.u(1);
      if (type > 1) return false;
      r.type = type == 0 ? EndpointType::kBulk : EndpointType::kInterrupt;
      r.size = static_cast<std::uint32_t>(in.u(4));
      r.transfers = static_cast<std::uint32_t>(in.u(4));
      break;
    }
    case Kind::kStopStreams:
    case Kind::kHotplug:
      break;
    case Kind::kTransfer: {
      r.endpoint = static_cast<std::uint8_t>(in.u(1));
      const std::uint64_t status = in.u(1);
      if (status > static_cast<std::uint64_t>(TransferStatus::kError)) return false;
      r.status = static_cast<TransferStatus>(status);
      r.data = in.bytes();
      break;
    }
  }
  if (is_call(r.kind)) {
    const std::uint64_t outcome = in.u(1);
    if (outcome > 2) return false;
    r.outcome = static_cast<Outcome>(outcome);
    if (r.outcome != Outcome::kOk) r.message = in.string();
  }
  return in.ok() && in.at_end();
}

}  // namespace

const char* to_string(UsbCaptureRecord::Kind kind) {
  switch (kind) {
    case Kind::kList:
      return "list";
    case Kind::kOpen:
      return "open";
    case Kind::kClaim:
      return "claim_interface";
    case Kind::kControl:
      return "control";
    case Kind::kClearHalt:
      return "clear_halt";
    case Kind::kStartStream:
      return "start_in_stream";
    case Kind::kStopStreams:
      return "stop_streams";
    case Kind::kTransfer:
      return "transfer";
    case Kind::kHotplug:
      return "hotplug";
  }
  return "unknown";
}

void encode_usb_capture_record(const UsbCaptureRecord& r, std::vector<std::uint8_t>& out) {
  // The head first, its length patched once the body is in: no second buffer per record.
  const std::size_t head = out.size();
  put(out, static_cast<std::uint64_t>(r.kind), 1);
  put(out, r.flags, 1);
  put(out, r.device, 2);
  put(out, 0, 4);
  put(out, static_cast<std::uint64_t>(r.t_ns), 8);
  switch (r.kind) {
    case Kind::kList:
      put(out, r.vendor, 2);
      put(out, r.product, 2);
      put(out, r.devices.size(), 4);
      for (const UsbDeviceInfo& d : r.devices) {
        put(out, static_cast<std::uint64_t>(d.bus), 2);
        put(out, static_cast<std::uint64_t>(d.address), 2);
        put(out, static_cast<std::uint64_t>(d.speed_mbps), 4);
        put_string(out, d.port_path);
        put_string(out, d.serial);
      }
      break;
    case Kind::kOpen:
      put_string(out, r.port_path);
      break;
    case Kind::kClaim:
      put(out, static_cast<std::uint64_t>(r.interface), 1);
      break;
    case Kind::kControl:
      put(out, r.request_type, 1);
      put(out, r.request, 1);
      put(out, r.value, 2);
      put(out, r.index, 2);
      put(out, r.length, 4);
      put_bytes(out, r.data);
      break;
    case Kind::kClearHalt:
      put(out, r.endpoint, 1);
      break;
    case Kind::kStartStream:
      put(out, r.endpoint, 1);
      put(out, r.type == EndpointType::kBulk ? 0 : 1, 1);
      put(out, r.size, 4);
      put(out, r.transfers, 4);
      break;
    case Kind::kStopStreams:
    case Kind::kHotplug:
      break;
    case Kind::kTransfer:
      put(out, r.endpoint, 1);
      put(out, static_cast<std::uint64_t>(r.status), 1);
      put_bytes(out, r.data);
      break;
  }
  if (is_call(r.kind)) {
    put(out, static_cast<std::uint64_t>(r.outcome), 1);
    if (r.outcome != Outcome::kOk) put_string(out, r.message);
  }
  const std::size_t length = out.size() - head - kHeadBytes;
  for (int k = 0; k < 4; ++k) out[head + 4 + k] = static_cast<std::uint8_t>(length >> (8 * k));
}

namespace {

// Decodes one record from its head and body; false with `problem` set when it is damaged.
bool decode_record(std::span<const std::uint8_t> head_bytes,
                   std::span<const std::uint8_t> body_bytes, std::size_t index, std::size_t pos,
                   UsbCaptureRecord& r, std::string& problem) {
  BodyReader head(head_bytes);
  head.u(1);
  r.flags = static_cast<std::uint8_t>(head.u(1));
  r.device = static_cast<std::uint16_t>(head.u(2));
  head.u(4);
  r.t_ns = static_cast<std::int64_t>(head.u(8));
  BodyReader body(body_bytes);
  if (!decode_body(body, r)) {
    problem = "record " + std::to_string(index) + " (" + to_string(r.kind) + ") at byte " +
              std::to_string(pos) + " has a malformed body";
    return false;
  }
  return true;
}

// The kind and body length from a head; false with `problem` set when they make no sense.
bool read_head(std::span<const std::uint8_t> head_bytes, std::size_t index, std::size_t pos,
               Kind& kind, std::uint32_t& length, std::string& problem) {
  BodyReader head(head_bytes);
  const std::uint64_t k = head.u(1);
  head.u(3);
  const std::uint64_t n = head.u(4);
  if (k < 1 || k > static_cast<std::uint64_t>(Kind::kHotplug) || n > kMaxBody) {
    problem = "record " + std::to_string(index) + " at byte " + std::to_string(pos) +
              " is damaged (kind " + std::to_string(k) + ", " + std::to_string(n) + " bytes)";
    return false;
  }
  kind = static_cast<Kind>(k);
  length = static_cast<std::uint32_t>(n);
  return true;
}

std::string ends_inside_head(std::size_t index, std::size_t pos) {
  return "capture ends inside the head of record " + std::to_string(index) + " at byte " +
         std::to_string(pos);
}

std::string ends_inside_record(std::size_t index, Kind kind, std::size_t pos) {
  return "capture ends inside record " + std::to_string(index) + " (" + to_string(kind) +
         ") at byte " + std::to_string(pos);
}

std::string back_in_time(std::size_t index, std::size_t pos) {
  return "record " + std::to_string(index) + " at byte " + std::to_string(pos) +
         " goes back in time";
}

}  // namespace

UsbCapture parse_usb_capture(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < sizeof kUsbCaptureMagic ||
      std::memcmp(bytes.data(), kUsbCaptureMagic, sizeof kUsbCaptureMagic) != 0)
    throw Error("not a dco USB capture (no DCOUSBC1 signature)");
  UsbCapture c;
  std::size_t pos = sizeof kUsbCaptureMagic;
  c.bytes_read = pos;
  while (pos < bytes.size()) {
    const std::size_t index = c.records.size();
    if (bytes.size() - pos < kHeadBytes) {
      c.problem = ends_inside_head(index, pos);
      break;
    }
    UsbCaptureRecord r;
    std::uint32_t length = 0;
    if (!read_head(bytes.subspan(pos, kHeadBytes), index, pos, r.kind, length, c.problem)) break;
    if (bytes.size() - pos - kHeadBytes < length) {
      c.problem = ends_inside_record(index, r.kind, pos);
      break;
    }
    if (!decode_record(bytes.subspan(pos, kHeadBytes), bytes.subspan(pos + kHeadBytes, length),
                       index, pos, r, c.problem))
      break;
    if (!c.records.empty() && r.t_ns < c.records.back().t_ns) {
      c.problem = back_in_time(index, pos);
      break;
    }
    c.records.push_back(std::move(r));
    pos += kHeadBytes + length;
    c.bytes_read = pos;
  }
  return c;
}

UsbCaptureReader::UsbCaptureReader(const std::string& path) : path_(path) {
  if (is_special_file(path))
    throw Error("USB capture '" + path + "': not a capture file (a directory, a device or a pipe)");
  file_ = std::fopen(path.c_str(), "rb");
  if (!file_) throw Error("USB capture '" + path + "': cannot open: " + std::strerror(errno));
  char magic[sizeof kUsbCaptureMagic] = {};
  if (std::fread(magic, 1, sizeof magic, file_) != sizeof magic ||
      std::memcmp(magic, kUsbCaptureMagic, sizeof magic) != 0) {
    std::fclose(file_);
    file_ = nullptr;
    throw Error("USB capture '" + path + "': not a dco USB capture (no DCOUSBC1 signature)");
  }
  offset_ = sizeof kUsbCaptureMagic;
}

UsbCaptureReader::~UsbCaptureReader() {
  if (file_) std::fclose(file_);
}

std::optional<UsbCaptureRecord> UsbCaptureReader::next() {
  if (!file_ || done_) return std::nullopt;
  auto stop = [this](std::string problem) {
    problem_ = std::move(problem);
    done_ = true;
    return std::nullopt;
  };
  std::uint8_t head[kHeadBytes];
  // A read the disk failed is no end of the capture: said apart from a capture cut short.
  const auto read_failed = [&] {
    return std::ferror(file_)
               ? stop("cannot read the USB capture at byte " + std::to_string(offset_) +
                      " (record " + std::to_string(index_) + "): a disk error")
               : std::nullopt;
  };
  const std::size_t got = std::fread(head, 1, kHeadBytes, file_);
  if (got < kHeadBytes && std::ferror(file_)) return read_failed();
  if (got == 0 && std::feof(file_)) {
    done_ = true;
    return std::nullopt;
  }
  if (got < kHeadBytes) return stop(ends_inside_head(index_, offset_));
  UsbCaptureRecord r;
  std::uint32_t length = 0;
  std::string problem;
  if (!read_head(head, index_, offset_, r.kind, length, problem)) return stop(problem);
  body_.resize(length);
  if (std::fread(body_.data(), 1, length, file_) != length) {
    if (std::ferror(file_)) return read_failed();
    return stop(ends_inside_record(index_, r.kind, offset_));
  }
  if (!decode_record(head, body_, index_, offset_, r, problem)) return stop(problem);
  if (index_ > 0 && r.t_ns < last_t_ns_) return stop(back_in_time(index_, offset_));
  last_t_ns_ = r.t_ns;
  ++index_;
  offset_ += kHeadBytes + length;
  return r;
}

}  // namespace dco::drivers
