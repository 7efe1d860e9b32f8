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

// The stereo thread's last waits for the later stages, so a frame's time held up at the entry
// counts every one of them since it came (a slot, then room in a queue: two waits a frame), not
// only the last. Fixed room, no allocation; the thread's waits never overlap.
class HoldUps {
 public:
  using Clock = std::chrono::steady_clock;
  static constexpr std::size_t kKept = 8;

  void begin(Clock::time_point at);  // a wait starts; it lasts until end()
  void end(Clock::time_point at);
  void clear();
  // ms of [from, to] spent in the kept waits (one still going counts up to `to`).
  double ms_within(Clock::time_point from, Clock::time_point to) const;

 private:
  struct Wait {
    Clock::time_point since, until;
  };
  std::array<Wait, kKept> waits_{};
  std::size_t count_ = 0, next_ = 0;
};

// Whether the stereo stage should take a frame from the entry as a flow neighbour only (late):
// when it waited there longer than deadline_ms and either waited longer than `share` of the
// frame interval or spent more than deadline_ms of its wait while the stereo thread waited for
// the later stages (held_up_ms). Waiting for the stereo stage's own work, a frame is worth its
// depth up to a share of the interval: the next one would start later than its wait saved.
// Waiting for the later stages, it is not: a fresher frame will be taken as soon as they let it.
// deadline_ms <= 0: never late.
bool late_at_entry(double waited_ms, double held_up_ms, double deadline_ms, double share,
                   double interval_ms);

}  // namespace dco::pipeline::runtime
