#include "dco/indemind/clock_map.hpp"

#include <algorithm>
#include <cmath>

namespace dco::indemind {
namespace {

constexpr std::int64_t kStableSpanNs = 2'000'000'000;

std::int64_t floor_div(std::int64_t a, std::int64_t b) {
  return a / b - ((a % b != 0) && ((a < 0) != (b < 0)));
}

}  // namespace

ClockMap::ClockMap(std::int64_t bucket_ns, std::size_t buckets)
    : bucket_ns_(std::max<std::int64_t>(bucket_ns, 1)),
      max_buckets_(std::max<std::size_t>(buckets, 3)) {}

void ClockMap::reset() {
  buckets_.clear();
  slope_ = offset_at_ref_ = 0;
}

void ClockMap::add(std::int64_t device_ns, std::int64_t host_ns) {
  const std::int64_t offset = host_ns - device_ns;
  const std::int64_t index = floor_div(device_ns, bucket_ns_);
  if (buckets_.empty() || index > buckets_.back().index) {
    buckets_.push_back({index, device_ns, offset});
    if (buckets_.size() > max_buckets_) buckets_.pop_front();
  } else {
    // Samples reach back at most into the bucket before (IMU reports of the previous frame).
    auto it = std::find_if(buckets_.rbegin(), buckets_.rend(),
                           [&](const Bucket& b) { return b.index == index; });
    if (it == buckets_.rend() || offset >= it->offset_ns) return;
    it->offset_ns = offset;
    it->device_ns = device_ns;
  }
  refit();
}

void ClockMap::refit() {
  // The newest bucket is still filling: its minimum may be one late sample, and a line through it
  // would swing with every sample that lowers it. Fit the complete buckets only, once there are
  // three; until then the least offset is the estimate.
  const std::size_t n_fit = buckets_.size() - 1;
  ref_device_ = buckets_.back().device_ns;
  double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < n_fit; ++i) {
    const double x = static_cast<double>(buckets_[i].device_ns - ref_device_);
    const double y = static_cast<double>(buckets_[i].offset_ns);
    n += 1;
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
  }
  const double det = n * sxx - sx * sx;
  if (n >= 3 && det > 0) {
    slope_ = (n * sxy - sx * sy) / det;
    offset_at_ref_ = (sy - slope_ * sx) / n;
  } else {
    slope_ = 0;
    offset_at_ref_ = static_cast<double>(
        std::min_element(buckets_.begin(), buckets_.end(), [](const Bucket& a, const Bucket& b) {
          return a.offset_ns < b.offset_ns;
        })->offset_ns);
  }
}

std::int64_t ClockMap::to_host(std::int64_t device_ns) const {
  if (buckets_.empty()) return device_ns;
  const double offset = offset_at_ref_ + slope_ * static_cast<double>(device_ns - ref_device_);
  return device_ns + static_cast<std::int64_t>(std::llround(offset));
}

bool ClockMap::stable() const {
  return buckets_.size() >= 4 &&
         buckets_.back().device_ns - buckets_.front().device_ns >= kStableSpanNs;
}

}  // namespace dco::indemind
