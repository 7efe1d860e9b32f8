#pragma once

#include <cstdint>
#include <vector>

namespace dco::pipeline::runtime {

// Durations in milliseconds in fixed buckets, so recording never allocates: 0.05 ms wide up to
// 100 ms (where the fixed-latency budget lives), then 0.5 % wider each up to 60 s; longer ones
// land in the last bucket. Percentiles are read back to within one bucket.
class Histogram {
 public:
  static constexpr double kLinearStepMs = 0.05;
  static constexpr double kLinearLimitMs = 100.0;
  static constexpr double kGrowth = 1.005;
  static constexpr double kCapMs = 60000.0;

  Histogram();

  void record(double ms);  // negative durations count as 0
  void clear();

  long count() const { return count_; }
  double mean_ms() const { return count_ > 0 ? sum_ms_ / count_ : 0.0; }
  double min_ms() const { return count_ > 0 ? min_ms_ : 0.0; }
  double max_ms() const { return count_ > 0 ? max_ms_ : 0.0; }
  // Nearest-rank percentile, p in [0, 100]: the middle of the bucket that holds it, kept within
  // the smallest and largest recorded value. 0 when nothing was recorded.
  double percentile(double p) const;

  static int bucket_of(double ms);
  static double bucket_low(int bucket);
  static double bucket_high(int bucket);
  static int bucket_count();

 private:
  std::vector<std::uint32_t> buckets_;
  long count_ = 0;
  double sum_ms_ = 0, min_ms_ = 0, max_ms_ = 0;
};

}  // namespace dco::pipeline::runtime
