#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "dco/indemind/uvc_payload.hpp"

namespace dco::indemind {

// Counts of what the assembler saw; every payload and every frame start lands in exactly one bin.
struct AssemblerCounters {
  std::uint64_t payloads = 0;
  std::uint64_t bad_payloads = 0;  // unparsable header: its frame is dropped
  std::uint64_t frames = 0;        // complete, exactly sized frames handed out
  std::uint64_t short_frames = 0;  // ended with fewer bytes than a frame holds
  std::uint64_t oversized_frames = 0;
  std::uint64_t error_frames = 0;    // a payload carried the UVC error bit
  std::uint64_t corrupt_frames = 0;  // contained a bad payload
  std::uint64_t unread_frames = 0;   // complete, but replaced before take_frame()
};

// Rebuilds video frames from UVC bulk payloads. A frame ends at the EOF bit or when the frame id
// toggles, and counts only with exactly `frame_bytes` bytes and no error or bad payload in it: a
// torn or padded frame never reaches stereo matching. Buffers are allocated once.
class FrameAssembler {
 public:
  explicit FrameAssembler(std::size_t frame_bytes);

  // Returns true when this payload completed a frame; take it with take_frame().
  bool feed(std::span<const std::uint8_t> payload);

  // Swaps the completed frame into `out` (which should hold a previous frame's buffer so nothing
  // is allocated). Returns false when no frame is ready.
  bool take_frame(std::vector<std::uint8_t>& out);

  // Forgets a partly received frame (stream restart, unplug) without counting it.
  void reset();

  std::size_t frame_bytes() const { return frame_bytes_; }
  const AssemblerCounters& counters() const { return counters_; }

 private:
  void start(bool fid);
  void finish();

  std::size_t frame_bytes_;
  std::vector<std::uint8_t> current_, ready_;
  std::size_t filled_ = 0;
  bool active_ = false, fid_ = false, overflow_ = false, device_error_ = false, corrupt_ = false;
  bool has_ready_ = false;
  AssemblerCounters counters_;
};

}  // namespace dco::indemind
