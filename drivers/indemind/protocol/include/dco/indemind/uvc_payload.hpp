#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace dco::indemind {

// The header that starts every UVC payload (UVC 1.1 §2.4.3.3). On this bulk-only device each bulk
// transfer of dwMaxPayloadTransferSize bytes carries one payload.
struct UvcPayloadHeader {
  std::uint8_t length = 0;           // bHeaderLength: 2, 6, 8 or 12
  bool fid = false;                  // frame id, toggles at each new frame
  bool eof = false;                  // last payload of a frame
  bool error = false;                // the device flagged this payload
  std::optional<std::uint32_t> pts;  // presentation time, device clock
  std::optional<std::uint32_t> scr_stc;
  std::optional<std::uint16_t> scr_sof;
};

enum class PayloadFault {
  kNone,
  kEmpty,            // zero bytes: not even a header
  kBadHeaderLength,  // bHeaderLength < 2, beyond the payload, or not what the PTS/SCR flags imply
  kNoEndOfHeader,    // the EOH bit (bit 7) is clear
};
const char* to_string(PayloadFault fault);

struct ParsedPayload {
  PayloadFault fault = PayloadFault::kNone;
  UvcPayloadHeader header;
  std::span<const std::uint8_t> data;  // image bytes after the header
};

ParsedPayload parse_uvc_payload(std::span<const std::uint8_t> payload);

// Writes a header with the given flags (for the simulated device and tests). `pts` adds the
// 4-byte PTS field.
std::vector<std::uint8_t> make_uvc_header(bool fid, bool eof, bool error,
                                          std::optional<std::uint32_t> pts = std::nullopt);

}  // namespace dco::indemind
