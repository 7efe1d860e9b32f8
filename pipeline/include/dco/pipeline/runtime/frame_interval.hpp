#pragma once

#include <array>
#include <chrono>
#include <cstddef>

namespace dco::pipeline::runtime {

// The camera's frame interval, from the capture times of the frames pushed: the median of the
// last kSamples intervals, so a frame the camera or the source lost now and then (a double
// interval) or one delivered late does not move it. Intervals of 0 or less (a repeated or
// reset timestamp) and of kMaxMs or more (a pause, a restarted recording) are not samples. It
// never allocates.
class FrameInterval {
 public:
  using Clock = std::chrono::steady_clock;
  static constexpr std::size_t kSamples = 8;
  static constexpr double kMaxMs = 1000.0;

  // The next frame's capture time.
  void add(Clock::time_point capture);
  // Forgets every sample: the next capture time starts a new sequence.
  void clear();
  // The median of the samples in ms (the upper middle one of an even count); 0 before two
  // frames.
  double ms() const;

 private:
  std::array<double, kSamples> samples_{};
  std::size_t count_ = 0, next_ = 0;
  Clock::time_point last_{};
  bool has_last_ = false;
};

}  // namespace dco::pipeline::runtime
