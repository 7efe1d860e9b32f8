#include "dco/pipeline/runtime/histogram.hpp"

#include <algorithm>
#include <cmath>

namespace dco::pipeline::runtime {
namespace {

const int kLinearBuckets =
    static_cast<int>(std::lround(Histogram::kLinearLimitMs / Histogram::kLinearStepMs));
const int kLogBuckets = static_cast<int>(std::ceil(
    std::log(Histogram::kCapMs / Histogram::kLinearLimitMs) / std::log(Histogram::kGrowth)));

}  // namespace

Histogram::Histogram() : buckets_(static_cast<std::size_t>(bucket_count()), 0) {}

int Histogram::bucket_count() {
  return kLinearBuckets + kLogBuckets + 1;
}

int Histogram::bucket_of(double ms) {
  if (!(ms > 0)) return 0;
  if (ms < kLinearLimitMs)
    return std::min(static_cast<int>(ms / kLinearStepMs), kLinearBuckets - 1);
  if (!(ms < kCapMs)) return kLinearBuckets + kLogBuckets;  // the overflow bucket, +inf too
  const int log_bucket = static_cast<int>(std::log(ms / kLinearLimitMs) / std::log(kGrowth));
  return kLinearBuckets + std::min(log_bucket, kLogBuckets);
}

double Histogram::bucket_low(int bucket) {
  if (bucket < kLinearBuckets) return bucket * kLinearStepMs;
  return kLinearLimitMs * std::pow(kGrowth, bucket - kLinearBuckets);
}

double Histogram::bucket_high(int bucket) {
  if (bucket < kLinearBuckets) return (bucket + 1) * kLinearStepMs;
  if (bucket - kLinearBuckets >= kLogBuckets) return INFINITY;  // the overflow bucket
  return kLinearLimitMs * std::pow(kGrowth, bucket - kLinearBuckets + 1);
}

void Histogram::record(double ms) {
  ms = std::max(ms, 0.0);
  ++buckets_[static_cast<std::size_t>(bucket_of(ms))];
  min_ms_ = count_ == 0 ? ms : std::min(min_ms_, ms);
  max_ms_ = count_ == 0 ? ms : std::max(max_ms_, ms);
  sum_ms_ += ms;
  ++count_;
}

void Histogram::clear() {
  std::fill(buckets_.begin(), buckets_.end(), 0u);
  count_ = 0;
  sum_ms_ = min_ms_ = max_ms_ = 0;
}

double Histogram::percentile(double p) const {
  if (count_ == 0) return 0.0;
  const long rank = std::clamp(
      static_cast<long>(std::ceil(std::clamp(p, 0.0, 100.0) / 100.0 * count_)), 1L, count_);
  long seen = 0;
  for (std::size_t b = 0; b < buckets_.size(); ++b) {
    seen += buckets_[b];
    if (seen >= rank) {
      const int bucket = static_cast<int>(b);
      if (bucket == bucket_count() - 1) return max_ms_;  // overflow: no upper edge
      const double high = std::min(bucket_high(bucket), max_ms_);
      const double mid = 0.5 * (bucket_low(bucket) + high);
      return std::clamp(mid, min_ms_, max_ms_);
    }
  }
  return max_ms_;
}

}  // namespace dco::pipeline::runtime
