#include "dco/daemon/warning_pacer.hpp"

#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

namespace dco::daemon {
namespace {

constexpr std::int64_t kS = 1'000'000'000;

// The seconds at which a fault that never ends is reported, asked once a second for `seconds`.
std::vector<std::int64_t> reports_of_a_lasting_fault(std::int64_t seconds) {
  WarningPacer pacer;
  std::vector<std::int64_t> at;
  for (std::int64_t t = 0; t < seconds; ++t)
    if (pacer.due(t * kS, true)) at.push_back(t);
  return at;
}

TEST(WarningPacer, ALastingFaultIsReportedAtOnceThenEverLessOften) {
  EXPECT_EQ(reports_of_a_lasting_fault(200), (std::vector<std::int64_t>{0, 10, 30, 70, 150}));
  // A day: the intervals stop growing at an hour.
  const std::vector<std::int64_t> day = reports_of_a_lasting_fault(86400);
  EXPECT_LT(day.size(), 40u);
  EXPECT_GT(day.size(), 20u);
  for (std::size_t i = 1; i < day.size(); ++i) EXPECT_LE(day[i] - day[i - 1], 3600);
  EXPECT_EQ(day[day.size() - 1] - day[day.size() - 2], 3600);
}

TEST(WarningPacer, NothingNewIsNeverReported) {
  WarningPacer pacer;
  for (std::int64_t t = 0; t < 100; ++t) EXPECT_FALSE(pacer.due(t * kS, false));
}

TEST(WarningPacer, AFaultThatEndedAndCameBackIsReportedAtOnce) {
  WarningPacer pacer;
  EXPECT_TRUE(pacer.due(0, true));
  EXPECT_FALSE(pacer.due(5 * kS, true));    // within the first interval: counted for later
  EXPECT_TRUE(pacer.due(10 * kS, true));    // the next interval is 20 s
  EXPECT_FALSE(pacer.due(30 * kS, false));  // a whole interval with nothing new: over
  EXPECT_TRUE(pacer.due(31 * kS, true));    // a new fault: at once
  EXPECT_FALSE(pacer.due(35 * kS, true));
  EXPECT_TRUE(pacer.due(41 * kS, true));  // and paced from the start again
}

}  // namespace
}  // namespace dco::daemon
