#pragma once

#include <chrono>

namespace dco {

// Wall time of a stage and of its steps, in milliseconds (steady clock).
class Stopwatch {
 public:
  using Clock = std::chrono::steady_clock;

  Stopwatch() : start_(Clock::now()), lap_(start_) {}

  // Time since the previous lap (or the start); starts the next lap.
  double lap_ms() {
    const auto now = Clock::now();
    const double ms = std::chrono::duration<double, std::milli>(now - lap_).count();
    lap_ = now;
    return ms;
  }
  // Time since the previous lap, the lap going on.
  double since_lap_ms() const {
    return std::chrono::duration<double, std::milli>(Clock::now() - lap_).count();
  }
  // Time from the start to the latest lap, so it equals the sum of the laps.
  double total_ms() const {
    return std::chrono::duration<double, std::milli>(lap_ - start_).count();
  }

 private:
  Clock::time_point start_, lap_;
};

}  // namespace dco
