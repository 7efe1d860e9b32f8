#include "dco/pipeline/runtime/frame_interval.hpp"

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

}  // namespace dco::pipeline::runtime
