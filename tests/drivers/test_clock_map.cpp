#include <gtest/gtest.h>

#include <random>

#include "dco/indemind/clock_map.hpp"

namespace dco::indemind {
namespace {

// Device time runs 80 ppm slow against the host; arrivals come 0.5 ms plus up to 3 ms of jitter
// after the event. The map must find the event's host time within the least delay's reach.
TEST(ClockMap, FollowsOffsetAndSkewUnderJitter) {
  ClockMap map;
  std::mt19937 rng(3);
  std::uniform_int_distribution<std::int64_t> jitter(0, 3'000'000);
  const std::int64_t offset = 5'000'000'000, least = 500'000;
  const double skew = 80e-6;
  auto host_of = [&](std::int64_t device) {
    return offset + static_cast<std::int64_t>(static_cast<double>(device) * (1 + skew));
  };
  EXPECT_FALSE(map.stable());
  for (std::int64_t device = 0; device < 20'000'000'000; device += 1'000'000) {
    map.add(device, host_of(device) + least + jitter(rng));
  }
  EXPECT_TRUE(map.stable());
  EXPECT_NEAR(map.skew_ppm(), 80, 10);
  const std::int64_t probe = 20'000'000'000;
  // The lower envelope is the event plus the least delay.
  EXPECT_NEAR(static_cast<double>(map.to_host(probe) - host_of(probe)), least, 150'000);
}

TEST(ClockMap, ResetForgetsTheOldTimeLine) {
  ClockMap map;
  for (std::int64_t t = 0; t < 100; ++t) map.add(t * 1'000'000, t * 1'000'000 + 7'000'000);
  EXPECT_EQ(map.to_host(200'000'000), 207'000'000);
  map.reset();
  EXPECT_EQ(map.buckets(), 0u);
  EXPECT_EQ(map.to_host(5), 5);
  map.add(0, 1'000);
  EXPECT_EQ(map.to_host(10), 1'010);
}

// 1 kHz samples 1.5 ms after their device time, but the first of the third bucket (500 ms) comes
// 4 ms late. That bucket is still filling: a line through it would bend the map by its single
// sample, and the next sample, on time again, would map before the late one.
TEST(ClockMap, ALateSampleInTheNewestBucketDoesNotBendTheMap) {
  ClockMap map;
  const std::int64_t delay = 1'500'000, late = 4'000'000;
  std::int64_t previous = 0;
  for (std::int64_t device = 0; device <= 3'000'000'000; device += 1'000'000) {
    map.add(device, device + delay + (device == 500'000'000 ? late : 0));
    const std::int64_t stamp = map.to_host(device);
    EXPECT_GT(stamp, previous) << device;
    EXPECT_NEAR(static_cast<double>(stamp - device), static_cast<double>(delay), 1'000.0) << device;
    previous = stamp;
  }
}

}  // namespace
}  // namespace dco::indemind
