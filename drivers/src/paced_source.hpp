#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <span>
#include <thread>

#include "dco/drivers/frame_source.hpp"

namespace dco::drivers {

// The thread, pacing and stop/start of sources that make their frames on demand (synthetic
// scenes, recordings): frame k is due at start + k / fps; a source that falls behind does not
// burst to catch up. Subclasses fill frames in produce() and call stop() in their destructor.
class PacedSource : public FrameSource {
 public:
  void start(FrameSink& sink) override;
  void stop() override;

 protected:
  // Fills the views with frame `seq`; they must stay valid until the next call. Returns false
  // after the last frame of a finite source; throws dco::Error when the source cannot go on.
  virtual bool produce(std::uint64_t seq, ImageView<const std::uint8_t>& left,
                       ImageView<const std::uint8_t>& right) = 0;
  // The number frame `counter` (0, 1, ...) is delivered with, asked right after produce() made
  // it: the counter itself, or the number a recording gave the frame.
  virtual std::uint64_t frame_number(std::uint64_t counter) const { return counter; }
  // The IMU samples that came with the frame produce() made (a recording's), stamped on the time
  // line of `capture_ns`, the time the frame is delivered with; none by default.
  virtual std::span<const ImuSample> frame_imu(std::int64_t /*capture_ns*/) { return {}; }
  // Sets StereoFrame::follows_gap and starts_run of the frame produce() made: a recording's,
  // found on its recorded stamps and frame numbers. Frames made on demand have neither.
  virtual void mark_sequence(StereoFrame& /*frame*/) const {}
  // After this many frames the source keeps running but delivers nothing more: a camera that hung
  // (0 = never).
  void set_stall_after(std::uint64_t frames) { stall_after_ = frames; }

 private:
  void run(std::stop_token stop, FrameSink& sink);

  std::uint64_t next_seq_ = 0;
  std::uint64_t stall_after_ = 0;
  std::mutex mutex_;
  std::condition_variable_any wake_;
  std::jthread thread_;
};

}  // namespace dco::drivers
