#pragma once

#include <array>
#include <cstdint>

namespace dco::drivers {

// Which frames of a camera's stream follow a gap: a replug, a stream restarted after a stall, a
// suspend, or (in a recorded log) another run. The frames before such a frame are no neighbours
// of it in time, so the pipeline starts a new sequence there instead of taking flow and
// stability against them. The rule looks at the capture stamps alone, so a replay of the
// recorded stamps cuts where the live run did.
class CaptureGaps {
 public:
  // A gap is longer than this and than kIntervals of the stream's recent frame intervals.
  static constexpr std::int64_t kMinGapNs = 250'000'000;
  static constexpr std::int64_t kIntervals = 4;

  // For each frame in delivery order: whether it follows a gap (or a stamp at or before the
  // previous one's, which no single run makes). The first frame follows none, and a frame right
  // after one that followed a gap follows none unless its stamp does not rise.
  bool follows_gap(std::int64_t capture_ns);

 private:
  // The shortest of the last few intervals: a frame the camera dropped lengthens one interval,
  // not the stream's rate.
  std::int64_t shortest_interval() const;

  static constexpr std::size_t kRecent = 8;
  std::array<std::int64_t, kRecent> recent_{};
  std::size_t recent_count_ = 0, recent_next_ = 0;
  std::int64_t previous_ns_ = 0;
  bool has_previous_ = false;
  bool last_was_gap_ = false;
};

}  // namespace dco::drivers
