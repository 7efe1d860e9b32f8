#include "dco/daemon/raw_recorder.hpp"

#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "dco/core/image.hpp"

namespace dco::daemon {
namespace {

// Offers `outcomes.size()` pairs to a recorder whose sender answers each in turn: "sent",
// "held" (still in its send after the wait) or "failed" (throws); deterministic, so none is
// dropped.
RawRecorder::Counts record(const std::vector<std::string>& outcomes, std::string& last_error,
                           std::vector<std::uint64_t>& sent_frames) {
  Image<std::uint8_t> left(16, 8), right(16, 8);
  left.fill(40);
  right.fill(90);
  RawRecorderOptions options;
  options.never_drop = true;
  std::size_t next = 0;
  RawRecorder recorder("[camera]\n", options, [&](const ::dco::raw_stereo_t& m) {
    const std::string& outcome = outcomes.at(next++);
    if (outcome == "failed") throw Error("LCM publish on DCO_RAW failed");
    sent_frames.push_back(static_cast<std::uint64_t>(m.frame_seq));
    return outcome == "sent";
  });
  for (std::size_t i = 0; i < outcomes.size(); ++i) {
    drivers::StereoFrame frame;
    frame.seq = 10 + i;
    frame.capture_ns = static_cast<std::int64_t>(i) * 20'000'000;
    frame.left = left.cview();
    frame.right = right.cview();
    recorder.offer(frame);
  }
  const RawRecorder::Counts counts = recorder.close();
  last_error = recorder.last_error();
  return counts;
}

TEST(RawRecorder, APairStillInItsSendIsHeldNotLost) {
  std::string error;
  std::vector<std::uint64_t> sent;
  const RawRecorder::Counts n = record({"sent", "held", "failed", "sent"}, error, sent);
  EXPECT_EQ(n.recorded, 2u);
  EXPECT_EQ(n.held, 1u);
  EXPECT_EQ(n.failed, 1u);
  EXPECT_EQ(n.dropped, 0u);
  EXPECT_EQ(n.oversized, 0u);
  EXPECT_EQ(sent, (std::vector<std::uint64_t>{10, 11, 13}));
  EXPECT_EQ(error, "LCM publish on DCO_RAW failed");
}

TEST(RawRecorder, AHeldPairIsTheLastErrorWhenItCameLast) {
  std::string error;
  std::vector<std::uint64_t> sent;
  const RawRecorder::Counts n = record({"failed", "held"}, error, sent);
  EXPECT_EQ(n.recorded, 0u);
  EXPECT_EQ(n.held, 1u);
  EXPECT_EQ(n.failed, 1u);
  EXPECT_NE(error.find("raw frame 11 still in its send"), std::string::npos) << error;
}

}  // namespace
}  // namespace dco::daemon
