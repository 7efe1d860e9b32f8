#pragma once

#include <algorithm>
#include <cstdint>

namespace dco::daemon {

// When a fault that lasts (no network for LCM, raw pairs that cannot go out) is worth another
// log line: the first at once, then after 10 s, 20 s, 40 s and so on up to an hour apart, each
// line counting what happened since the one before. A day without a network is then some thirty
// lines in the journal, not thousands. Once a whole interval passes with nothing new, the fault
// is over and the next one is reported at once again.
class WarningPacer {
 public:
  static constexpr std::int64_t kFirstIntervalNs = 10'000'000'000;
  static constexpr std::int64_t kLongestIntervalNs = 3'600'000'000'000;

  // Whether to report now; `news`: whether anything happened since the last report.
  bool due(std::int64_t now_ns, bool news) {
    if (!reported_) {
      if (news) mark(now_ns, kFirstIntervalNs);
      return news;
    }
    if (now_ns - last_ns_ < interval_ns_) return false;
    if (!news) {
      reported_ = false;  // quiet for a whole interval: the fault is over
      return false;
    }
    mark(now_ns, std::min(interval_ns_ * 2, kLongestIntervalNs));
    return true;
  }

 private:
  void mark(std::int64_t now_ns, std::int64_t next_interval_ns) {
    reported_ = true;
    last_ns_ = now_ns;
    interval_ns_ = next_interval_ns;
  }

  bool reported_ = false;
  std::int64_t last_ns_ = 0;
  std::int64_t interval_ns_ = kFirstIntervalNs;
};

}  // namespace dco::daemon
