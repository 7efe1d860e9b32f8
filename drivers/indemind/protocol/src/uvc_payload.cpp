#include "dco/indemind/uvc_payload.hpp"

#include "dco/indemind/byte_order.hpp"

namespace dco::indemind {
namespace {

constexpr std::uint8_t kFid = 0x01, kEof = 0x02, kPts = 0x04, kScr = 0x08, kErr = 0x40, kEoh = 0x80;

}  // namespace

const char* to_string(PayloadFault fault) {
  switch (fault) {
    case PayloadFault::kNone:
      return "none";
    case PayloadFault::kEmpty:
      return "empty payload";
    case PayloadFault::kBadHeaderLength:
      return "bad header length";
    case PayloadFault::kNoEndOfHeader:
      return "no end-of-header bit";
  }
  return "unknown";
}

ParsedPayload parse_uvc_payload(std::span<const std::uint8_t> payload) {
  ParsedPayload out;
  if (payload.size() < 2) {
    out.fault = payload.empty() ? PayloadFault::kEmpty : PayloadFault::kBadHeaderLength;
    return out;
  }
  const std::uint8_t length = payload[0], info = payload[1];
  const std::size_t expected = 2u + ((info & kPts) ? 4u : 0u) + ((info & kScr) ? 6u : 0u);
  // Room for the fields its flags name, and at most the standard header's 12 bytes: a header
  // padded past its fields (which libuvc and uvcvideo take, skipping the rest) is taken too,
  // a length byte hit by corruption (no checksum guards it) mostly is not.
  constexpr std::size_t kMaxHeader = 12;
  if (length < expected || length > kMaxHeader || length > payload.size()) {
    out.fault = PayloadFault::kBadHeaderLength;
    return out;
  }
  if (!(info & kEoh)) {
    out.fault = PayloadFault::kNoEndOfHeader;
    return out;
  }
  UvcPayloadHeader& h = out.header;
  h.length = length;
  h.fid = info & kFid;
  h.eof = info & kEof;
  h.error = info & kErr;
  std::size_t at = 2;
  if (info & kPts) {
    h.pts = read_le32(payload, at);
    at += 4;
  }
  if (info & kScr) {
    h.scr_stc = read_le32(payload, at);
    h.scr_sof = read_le16(payload, at + 4);
  }
  out.data = payload.subspan(length);
  return out;
}

std::vector<std::uint8_t> make_uvc_header(bool fid, bool eof, bool error,
                                          std::optional<std::uint32_t> pts) {
  std::vector<std::uint8_t> h(pts ? 6 : 2);
  h[0] = static_cast<std::uint8_t>(h.size());
  h[1] = static_cast<std::uint8_t>(kEoh | (fid ? kFid : 0) | (eof ? kEof : 0) | (error ? kErr : 0) |
                                   (pts ? kPts : 0));
  if (pts) write_le32(h, 2, *pts);
  return h;
}

}  // namespace dco::indemind
