#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>

namespace dco::indemind {

// Maps the module's time line (frame counter × nominal period, plus IMU ticks) to CLOCK_MONOTONIC.
// Host arrival times are the device times plus a transfer delay that is never below some minimum,
// so the map follows the lower envelope of (host − device): device time is cut into buckets, the
// smallest offset of each is kept, and a line through the last buckets' minima gives offset and
// skew. The skew matters because the device's real frame period differs from the nominal one.
// Constant memory, O(buckets) per sample at most. The map moves as it learns (a lower minimum, a
// new bucket in the fit), so two device times in order can map slightly out of order: a caller
// that needs rising stamps keeps them rising itself.
class ClockMap {
 public:
  explicit ClockMap(std::int64_t bucket_ns = 250'000'000, std::size_t buckets = 40);

  void add(std::int64_t device_ns, std::int64_t host_ns);
  void reset();

  // Host time of a device time; before the first sample, the device time itself.
  std::int64_t to_host(std::int64_t device_ns) const;

  // At least two seconds of buckets: the skew means something.
  bool stable() const;
  double skew_ppm() const { return slope_ * 1e6; }
  std::size_t buckets() const { return buckets_.size(); }

 private:
  struct Bucket {
    std::int64_t index = 0;
    std::int64_t device_ns = 0;  // where the minimum was seen
    std::int64_t offset_ns = 0;  // host − device, the least in this bucket
  };
  void refit();

  std::int64_t bucket_ns_;
  std::size_t max_buckets_;
  std::deque<Bucket> buckets_;
  std::int64_t ref_device_ = 0;  // the fit is offset_at_ref + slope × (device − ref)
  double offset_at_ref_ = 0, slope_ = 0;
};

}  // namespace dco::indemind
