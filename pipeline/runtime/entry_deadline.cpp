#include "dco/pipeline/runtime/entry_deadline.hpp"

#include <algorithm>

namespace dco::pipeline::runtime {

void FrameInterval::add(Clock::time_point capture) {
  if (has_last_) {
    const double ms = std::chrono::duration<double, std::milli>(capture - last_).count();
    if (ms > 0 && ms < kMaxMs) {
      samples_[next_] = ms;
      next_ = (next_ + 1) % kSamples;
      count_ = std::min(count_ + 1, kSamples);
    }
  }
  last_ = capture;
  has_last_ = true;
}

void FrameInterval::clear() {
  count_ = next_ = 0;
  has_last_ = false;
}

double FrameInterval::ms() const {
  if (count_ == 0) return 0.0;
  std::array<double, kSamples> sorted = samples_;
  const auto end = sorted.begin() + static_cast<std::ptrdiff_t>(count_);
  const auto middle = sorted.begin() + static_cast<std::ptrdiff_t>(count_ / 2);
  std::nth_element(sorted.begin(), middle, end);
  return *middle;
}

void HoldUps::begin(Clock::time_point at) {
  waits_[next_] = {at, Clock::time_point::max()};
  next_ = (next_ + 1) % kKept;
  count_ = std::min(count_ + 1, kKept);
}

void HoldUps::end(Clock::time_point at) {
  if (count_ > 0) waits_[(next_ + kKept - 1) % kKept].until = at;
}

void HoldUps::clear() {
  count_ = next_ = 0;
}

double HoldUps::ms_within(Clock::time_point from, Clock::time_point to) const {
  double ms = 0;
  for (std::size_t i = 0; i < count_; ++i) {
    const Wait& w = waits_[i];
    const Clock::time_point a = std::max(from, w.since), b = std::min(to, w.until);
    if (b > a) ms += std::chrono::duration<double, std::milli>(b - a).count();
  }
  return ms;
}

bool late_at_entry(double waited_ms, double held_up_ms, double deadline_ms, double share,
                   double interval_ms) {
  if (deadline_ms <= 0 || waited_ms <= deadline_ms) return false;
  if (held_up_ms > deadline_ms) return true;
  return waited_ms > share * interval_ms;
}

}  // namespace dco::pipeline::runtime
