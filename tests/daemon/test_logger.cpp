// dcod's log: what reaches the DCO_LOG forwarder.
#include "dco/daemon/logger.hpp"

#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace dco::daemon {
namespace {

using Lines = std::vector<std::pair<LogLevel, std::string>>;

// The daemon logs about its source and the log's settings before the publisher exists: the
// forwarder, once installed, gets those lines first.
TEST(Logger, AForwarderGetsWhatWasLoggedWhileItWasHeldFor) {
  Logger log;
  log.info("before anyone asked");  // not held: nobody will forward it
  log.hold_for_forward();
  log.info("the source");
  log.debug("below the level");
  log.warning("a key this build does not have");
  Lines got;
  log.set_forward([&](LogLevel l, std::string_view t) { got.emplace_back(l, std::string(t)); });
  log.error("after");
  const Lines want = {{LogLevel::kInfo, "the source"},
                      {LogLevel::kWarning, "a key this build does not have"},
                      {LogLevel::kError, "after"}};
  EXPECT_EQ(got, want);
}

TEST(Logger, HoldsAtMostItsLimitAndNothingOnceTheForwarderIsRemoved) {
  Logger log;
  log.hold_for_forward();
  for (std::size_t i = 0; i < Logger::kMaxHeld + 20; ++i) log.info("line " + std::to_string(i));
  Lines got;
  log.set_forward([&](LogLevel l, std::string_view t) { got.emplace_back(l, std::string(t)); });
  ASSERT_EQ(got.size(), Logger::kMaxHeld);
  EXPECT_EQ(got.front().second, "line 0");
  log.set_forward({});
  log.info("not held");
  std::size_t later = 0;
  log.set_forward([&](LogLevel, std::string_view) { ++later; });
  EXPECT_EQ(later, 0u);
}

}  // namespace
}  // namespace dco::daemon
