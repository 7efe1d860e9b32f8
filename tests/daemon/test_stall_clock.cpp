#include "dco/daemon/stall_clock.hpp"

#include <gtest/gtest.h>

namespace dco::daemon {
namespace {

constexpr std::int64_t kS = 1'000'000'000;

TEST(StallClock, AStartOrAFrameGivesTheTimeoutThenTheCameraIsStalled) {
  StallClock c;
  EXPECT_TRUE(c.healthy(2 * kS, 0, 0, false, 3));
  EXPECT_FALSE(c.healthy(4 * kS, 0, 0, false, 3));
  EXPECT_TRUE(c.healthy(4 * kS, 3 * kS, 0, false, 3));
  EXPECT_TRUE(c.healthy(5 * kS, 0, 3 * kS, false, 3));
}

// Unplugged for 6 s, then back: streaming again takes time, as at the start; the camera gets
// the whole timeout from its return, not from the last frame before the unplug.
TEST(StallClock, ACameraBackFromAnUnplugGetsTheTimeoutAgain) {
  StallClock c;
  const std::int64_t last_frame = 2 * kS;
  for (std::int64_t t = 2 * kS; t <= 8 * kS; t += kS / 4)
    EXPECT_TRUE(c.healthy(t, last_frame, 0, true, 3)) << t;
  EXPECT_TRUE(c.healthy(8 * kS + kS / 4, last_frame, 0, false, 3));
  EXPECT_EQ(c.since_ns(last_frame, 0), 8 * kS + kS / 4);
  EXPECT_TRUE(c.healthy(11 * kS, last_frame, 0, false, 3));
  // A replugged camera that never streams is stalled after the timeout.
  EXPECT_FALSE(c.healthy(11 * kS + kS / 2, last_frame, 0, false, 3));
}

}  // namespace
}  // namespace dco::daemon
