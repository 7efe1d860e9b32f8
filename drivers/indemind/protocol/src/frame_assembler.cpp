#include "dco/indemind/frame_assembler.hpp"

#include <algorithm>
#include <cstring>

namespace dco::indemind {

FrameAssembler::FrameAssembler(std::size_t frame_bytes)
    : frame_bytes_(frame_bytes), current_(frame_bytes), ready_(frame_bytes) {}

void FrameAssembler::start(bool fid) {
  active_ = true;
  fid_ = fid;
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
    has_ready_ = true;
  }
}

bool FrameAssembler::feed(std::span<const std::uint8_t> payload) {
  ++counters_.payloads;
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
    start(p.header.fid);
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

bool FrameAssembler::take_frame(std::vector<std::uint8_t>& out) {
  if (!has_ready_) return false;
  std::swap(ready_, out);
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
