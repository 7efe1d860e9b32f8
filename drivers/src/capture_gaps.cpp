#include "dco/drivers/capture_gaps.hpp"

#include <algorithm>
#include <utility>

namespace dco::drivers {

bool CaptureGaps::follows_gap(std::int64_t capture_ns) {
  const bool first = !has_previous_;
  // Unsigned: a damaged log's stamps wrap instead of overflowing.
  const auto interval = static_cast<std::int64_t>(static_cast<std::uint64_t>(capture_ns) -
                                                  static_cast<std::uint64_t>(previous_ns_));
  has_previous_ = true;
  previous_ns_ = capture_ns;
  if (first) return false;
  const bool after_gap = std::exchange(last_was_gap_, false);
  if (interval <= 0) return last_was_gap_ = true;
  // Never two in a row: the frame after a gap may come late because the consumer ended the
  // sequence before it took the gap's frame, and a slow consumer must not cut every frame.
  // In double: damaged stamps' intervals would overflow four times over.
  const bool gap =
      !after_gap && interval > kMinGapNs &&
      (recent_count_ == 0 ||
       static_cast<double>(interval) > kIntervals * static_cast<double>(shortest_interval()));
  last_was_gap_ = gap;
  // A gap joins the recent intervals too: only the shortest counts, and a camera slower than
  // kMinGapNs a frame then cuts once, at its second frame, not at every frame.
  recent_[recent_next_] = interval;
  recent_next_ = (recent_next_ + 1) % kRecent;
  recent_count_ = std::min(recent_count_ + 1, kRecent);
  return gap;
}

std::int64_t CaptureGaps::shortest_interval() const {
  return *std::min_element(recent_.begin(), recent_.begin() + static_cast<long>(recent_count_));
}

}  // namespace dco::drivers
