// The camera's frame number of each result, found by capture time.
#include "dco/daemon/frame_numbers.hpp"

#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

namespace dco::daemon {
namespace {

TEST(FrameNumbers, EachResultGetsTheNumberOfItsFrame) {
  FrameNumbers n;
  for (std::uint64_t seq = 1; seq <= 5; ++seq) n.record(static_cast<std::int64_t>(seq) * 10, seq);
  // Frame 2 was dropped at the entry: its number is never taken.
  EXPECT_EQ(n.take(10, 0), 1u);
  EXPECT_EQ(n.take(30, 0), 3u);
  EXPECT_EQ(n.take(50, 0), 5u);
  EXPECT_EQ(n.take(70, 99), 99u) << "a capture time never recorded";
}

// A camera that stamped several frames alike (a clock fault): results come in push order, so
// each takes the first number not handed out yet, not the newest with that stamp.
TEST(FrameNumbers, FramesStampedAlikeKeepTheirOrder) {
  FrameNumbers n;
  const std::vector<std::pair<std::int64_t, std::uint64_t>> pushed = {
      {100, 29}, {200, 30}, {200, 31}, {200, 32}, {300, 33}};
  for (const auto& [ns, seq] : pushed) n.record(ns, seq);
  std::vector<std::uint64_t> got;
  for (const auto& [ns, seq] : pushed) got.push_back(n.take(ns, 0));
  EXPECT_EQ(got, (std::vector<std::uint64_t>{29, 30, 31, 32, 33}));
}

// Past its room, the oldest records give way to the newest.
TEST(FrameNumbers, KeepsTheLatestRecords) {
  FrameNumbers n;
  for (std::uint64_t seq = 0; seq < 2000; ++seq) n.record(static_cast<std::int64_t>(seq), seq);
  EXPECT_EQ(n.take(1999, 7), 1999u);
  EXPECT_EQ(n.take(5, 7), 7u);
}

}  // namespace
}  // namespace dco::daemon
