#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <optional>
#include <utility>

#include "dco/core/priority_inheritance_mutex.hpp"

namespace dco::daemon {

// The camera's frame number of each result, found by its capture time: the runtime hands a
// result on with its capture time only. Every push is recorded (dropped frames too) for as long as
// a frame can be in flight: the stages plus up to runtime.release_latency_ms (1 s), 2.5 s of a
// 200 fps camera. Results come in push order, so where a camera stamped several frames alike
// (a clock fault) the first of them not yet handed out is the result's. Thread-safe: frames are
// recorded on the source's thread, taken on the release thread (which may run at SCHED_FIFO: the
// mutex lends the source's thread its priority).
class FrameNumbers {
 public:
  void record(std::int64_t capture_ns, std::uint64_t seq) {
    std::lock_guard lock(mutex_);
    pushed_[cursor_++ % pushed_.size()] = {capture_ns, seq};
  }

  // The number of the frame captured at `capture_ns`, or `fallback` when none was recorded.
  std::uint64_t take(std::int64_t capture_ns, std::uint64_t fallback) {
    std::lock_guard lock(mutex_);
    std::optional<std::uint64_t> next, newest;
    for (const auto& [ns, seq] : pushed_) {
      if (ns != capture_ns) continue;
      if (!newest || seq > *newest) newest = seq;
      if ((!last_ || seq > *last_) && (!next || seq < *next)) next = seq;
    }
    const std::optional<std::uint64_t> found = next ? next : newest;
    if (!found) return fallback;
    last_ = found;
    return *found;
  }

 private:
  PriorityInheritanceMutex mutex_;
  std::array<std::pair<std::int64_t, std::uint64_t>, 512> pushed_{};
  std::size_t cursor_ = 0;
  std::optional<std::uint64_t> last_;  // the number take() gave last
};

}  // namespace dco::daemon
