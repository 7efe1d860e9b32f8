#include "dco/indemind/frame_assembler.hpp"

#include <algorithm>
#include <cstring>

namespace dco::indemind {

FrameAssembler::FrameAssembler(std::size_t frame_bytes)
    : frame_bytes_(frame_bytes), current_(frame_bytes), ready_(frame_bytes) {}

void FrameAssembler::start(bool fid, std::int64_t arrival_ns) {
  active_ = true;
  fid_ = fid;
  current_first_ns_ = arrival_ns;
  filled_ = 0;
  overflow_ = device_error_ = corrupt_ = false;
}

void FrameAssembler::finish() {
  active_ = false;
  if (corrupt_) {
    ++counters_.corrupt_frames;
  } else if (device_error_) {
    ++counters_.error_frames;
  } else if (overflow_) {
    ++counters_.oversized_frames;
  } else if (filled_ < frame_bytes_) {
    ++counters_.short_frames;
  } else {
    ++counters_.frames;
    if (has_ready_) ++counters_.unread_frames;
    std::swap(current_, ready_);
    ready_first_ns_ = current_first_ns_;
    has_ready_ = true;
  }
}

bool FrameAssembler::feed(std::span<const std::uint8_t> payload, std::int64_t arrival_ns) {
  ++counters_.payloads;
  if (payload.empty()) {
    // A zero-length packet ends a bulk transfer that filled its last packet exactly; it carries
    // no header and no bytes of any frame (uvcvideo and libuvc skip it too).
    ++counters_.empty_payloads;
    return false;
  }
  const std::uint64_t frames_before = counters_.frames;
  const ParsedPayload p = parse_uvc_payload(payload);
  if (p.fault != PayloadFault::kNone) {
    ++counters_.bad_payloads;
    // Where its bytes belonged is unknown, so the frame it was part of cannot be trusted.
    if (active_) corrupt_ = true;
    return false;
  }
  if (active_ && p.header.fid != fid_) finish();
  if (!active_) {
    // A bare header between frames (some devices send one with EOF) starts nothing.
    if (p.data.empty()) return counters_.frames != frames_before;
    start(p.header.fid, arrival_ns);
  }
  if (p.header.error) device_error_ = true;
  const std::size_t room = frame_bytes_ - filled_;
  const std::size_t n = std::min(room, p.data.size());
  if (n > 0) std::memcpy(current_.data() + filled_, p.data.data(), n);
  filled_ += n;
  if (p.data.size() > room) overflow_ = true;
  if (p.header.eof) finish();
  return counters_.frames != frames_before;
}

bool FrameAssembler::take_frame(std::vector<std::uint8_t>& out, std::int64_t* first_arrival_ns) {
  if (!has_ready_) return false;
  std::swap(ready_, out);
  if (first_arrival_ns != nullptr) *first_arrival_ns = ready_first_ns_;
  // The buffer handed in becomes the next spare; keep it frame-sized.
  if (ready_.size() != frame_bytes_) ready_.resize(frame_bytes_);
  has_ready_ = false;
  return true;
}

void FrameAssembler::reset() {
  active_ = false;
  filled_ = 0;
}

}  // namespace dco::indemind
