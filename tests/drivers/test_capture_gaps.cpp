#include "dco/drivers/capture_gaps.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace dco::drivers {
namespace {

constexpr std::int64_t kMs = 1'000'000;

// Which of the frames stamped `stamps_ms` follow a gap.
std::vector<bool> gaps_of(const std::vector<std::int64_t>& stamps_ms) {
  CaptureGaps gaps;
  std::vector<bool> out;
  for (const std::int64_t t : stamps_ms) out.push_back(gaps.follows_gap(t * kMs));
  return out;
}

TEST(CaptureGaps, AStreamWithDroppedFramesHasNone) {
  // 30 fps, a frame dropped, then two: the stream's rate holds, only intervals grow.
  EXPECT_EQ(gaps_of({0, 33, 67, 133, 167, 267, 300}),
            (std::vector<bool>{false, false, false, false, false, false, false}));
}

TEST(CaptureGaps, APauseLongerThanAQuarterSecondAndFourFramesIsOne) {
  // 30 fps: 0.25 s is the bound (7.5 intervals); 251 ms past the last frame is a gap.
  EXPECT_EQ(gaps_of({0, 33, 67, 317, 350, 601, 634}),
            (std::vector<bool>{false, false, false, false, false, true, false}));
  // 5 fps: four intervals (800 ms) is the bound, not the quarter second.
  EXPECT_EQ(gaps_of({0, 200, 400, 1200, 1400, 2201, 2401}),
            (std::vector<bool>{false, false, false, false, false, true, false}));
}

TEST(CaptureGaps, ASlowCameraDroppingAFrameHasNone) {
  // 5 fps: 600 ms (two frames dropped) is past the quarter second but within four intervals.
  EXPECT_EQ(gaps_of({0, 200, 400, 1000, 1200}),
            (std::vector<bool>{false, false, false, false, false}));
}

TEST(CaptureGaps, TheRateIsTheLastEightIntervals) {
  // 30 fps, then 10 fps: once the eight intervals since the change are all 100 ms, 350 ms is
  // within four of them; while a 33 ms interval was among the last eight, it was a gap.
  EXPECT_EQ(gaps_of({0, 33, 133, 233, 333, 433, 533, 633, 733, 833, 1183}),
            (std::vector<bool>{false, false, false, false, false, false, false, false, false, false,
                               false}));
  EXPECT_EQ(
      gaps_of({0, 33, 133, 233, 333, 433, 533, 633, 733, 1083}),
      (std::vector<bool>{false, false, false, false, false, false, false, false, false, true}));
}

TEST(CaptureGaps, AStampThatDoesNotRiseIsAnotherRun) {
  EXPECT_EQ(gaps_of({1000, 1033, 1067, 5, 38, 38}),
            (std::vector<bool>{false, false, false, true, false, true}));
}

TEST(CaptureGaps, NeverTwoInARow) {
  // The frame after a gap came late too (its consumer ended the sequence first): no second cut.
  EXPECT_EQ(gaps_of({0, 33, 67, 1067, 1400, 1433, 2433}),
            (std::vector<bool>{false, false, false, true, false, false, true}));
}

TEST(CaptureGaps, ACameraSlowerThanTheBoundCutsOnceAtItsSecondFrame) {
  // 3 fps: its first interval has nothing to compare with; from then on its own rate is known.
  EXPECT_EQ(gaps_of({0, 333, 667, 1000, 1333, 1667}),
            (std::vector<bool>{false, true, false, false, false, false}));
}

TEST(CaptureGaps, DamagedStampsWrapInsteadOfOverflowing) {
  CaptureGaps gaps;
  EXPECT_FALSE(gaps.follows_gap(0));
  EXPECT_TRUE(gaps.follows_gap(INT64_MAX));
  EXPECT_FALSE(gaps.follows_gap(INT64_MIN));  // wrapped: one nanosecond after the last
  EXPECT_TRUE(gaps.follows_gap(0));           // wrapped: before the last
}

}  // namespace
}  // namespace dco::drivers
