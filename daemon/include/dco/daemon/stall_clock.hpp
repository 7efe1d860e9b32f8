#pragma once

#include <algorithm>
#include <cstdint>

namespace dco::daemon {

// Whether frames flow, for the watchdog. A frame is due within the stall timeout of the last
// publication, of the pipeline's first start, or of the camera's return from an unplug (which,
// like a start, needs its time to stream again). An unplugged camera is waited for, not a hang:
// a restart by the watchdog would not bring it back sooner.
class StallClock {
 public:
  // Called at every tick, so that no return from an unplug goes unseen.
  bool healthy(std::int64_t now_ns, std::int64_t last_publish_ns, std::int64_t start_ns,
               bool disconnected, double stall_timeout_s) {
    if (disconnected) {
      away_ = true;
      return true;
    }
    if (away_) {
      away_ = false;
      back_ns_ = now_ns;
    }
    return static_cast<double>(now_ns - since_ns(last_publish_ns, start_ns)) <
           stall_timeout_s * 1e9;
  }
  // Since when a frame has been due.
  std::int64_t since_ns(std::int64_t last_publish_ns, std::int64_t start_ns) const {
    return std::max({last_publish_ns, start_ns, back_ns_});
  }

 private:
  bool away_ = false;
  std::int64_t back_ns_ = 0;
};

}  // namespace dco::daemon
