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
  std::uint64_t empty_payloads = 0;  // zero-length transfers: no header, nothing to place
  std::uint64_t bad_payloads = 0;    // unparsable header: its frame is dropped
  std::uint64_t frames = 0;          // complete, exactly sized frames handed out
  std::uint64_t short_frames = 0;    // ended with fewer bytes than a frame holds
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

  // Returns true when this payload completed a frame; take it with take_frame(). `arrival_ns` is
  // when the payload reached the host (any clock): a frame keeps its first payload's.
  bool feed(std::span<const std::uint8_t> payload, std::int64_t arrival_ns = 0);

  // Swaps the completed frame into `out` (which should hold a previous frame's buffer so nothing
  // is allocated). Returns false when no frame is ready. `first_arrival_ns`, when given, gets the
  // arrival of the frame's first payload: the module sends it as readout begins, so it is the
  // host time nearest the frame start (the last one comes a readout later).
  bool take_frame(std::vector<std::uint8_t>& out, std::int64_t* first_arrival_ns = nullptr);

  // Forgets a partly received frame (stream restart, unplug) without counting it.
  void reset();

  std::size_t frame_bytes() const { return frame_bytes_; }
  const AssemblerCounters& counters() const { return counters_; }

 private:
  void start(bool fid, std::int64_t arrival_ns);
  void finish();

  std::size_t frame_bytes_;
  std::vector<std::uint8_t> current_, ready_;
  std::size_t filled_ = 0;
  bool active_ = false, fid_ = false, overflow_ = false, device_error_ = false, corrupt_ = false;
  bool has_ready_ = false;
  std::int64_t current_first_ns_ = 0, ready_first_ns_ = 0;
  AssemblerCounters counters_;
};

}  // namespace dco::indemind
