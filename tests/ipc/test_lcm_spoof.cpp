// "A spoofed DCO_DEPTH message from another process cannot make a client accept depth that the
// daemon did not write": the daemon, a spoofing process and a reader on a real udpm bus, inside a
// private network namespace so no multicast leaves the machine (see lcm_spoof_scenario.cpp).

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "support/commands.hpp"
#include "support/temp_dir.hpp"

namespace dco::ipc::testing {
namespace {

// The value after `key` in a line of "key value" pairs, -1 when absent.
long field(const std::string& line, const std::string& key) {
  std::istringstream in(line);
  std::string k;
  while (in >> k)
    if (k == key) {
      long v = -1;
      in >> v;
      return v;
    }
  return -1;
}

TEST(LcmSpoof, ForgedDescriptorsFromAnotherProcessAreNeverAccepted) {
  if (const std::string problem = dco::testing::private_network_problem(); !problem.empty())
    GTEST_SKIP() << "cannot set up a private network namespace (" << problem
                 << "); the udpm test never runs outside one";
  const std::string unshare = dco::testing::unshare_command();
  const std::string setup = dco::testing::kNetnsSetup;
  dco::testing::TempDir dir;
  constexpr int kFrames = 120;
  const std::string url = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304";
  // lo up with a multicast route: without the route LCM refuses to start.
  const dco::testing::CommandResult r = dco::testing::run_command(
      unshare + " sh -c '" + setup + " && exec \"$0\" \"$@\"' " + DCO_LCM_SPOOF_SCENARIO_EXE + " " +
      dir.path().string() + " '" + url + "' " + std::to_string(kFrames) + " 4000");
  ASSERT_EQ(r.status, 0) << r.output;
  const std::string& line = r.output;
  EXPECT_EQ(field(line, "daemon_rc"), 0) << line;
  EXPECT_EQ(field(line, "spoofer_rc"), 0) << line;
  EXPECT_EQ(field(line, "decode_errors"), 0) << line;
  // Whatever was accepted is exactly what the daemon wrote under that index.
  EXPECT_EQ(field(line, "bad_accepts"), 0) << line;
  // Every kind of descriptor that never named a frame in the ring was heard and refused.
  EXPECT_GE(field(line, "never_valid"), 6 * (kFrames / 2)) << line;
  EXPECT_EQ(field(line, "never_valid_accepted"), 0) << line;
  // A slot that is being rewritten is refused unless the read beat the writer (then it checked
  // out as the daemon's frame above). The writer reopens the slot microseconds after announcing
  // it, but a loaded machine can deschedule it for longer than the forgery takes to arrive, so
  // only most of these must be refused.
  EXPECT_GE(field(line, "being_written"), kFrames / 2) << line;
  EXPECT_LE(field(line, "being_written_accepted"), field(line, "being_written") / 2) << line;
  // Genuine frames, and replays of them (their forged fields ignored), are read.
  EXPECT_GE(field(line, "genuine"), kFrames * 9 / 10) << line;
  EXPECT_GE(field(line, "genuine_accepted"), field(line, "genuine") * 9 / 10) << line;
  EXPECT_GE(field(line, "replay_accepted"), field(line, "replay") * 9 / 10) << line;
}

}  // namespace
}  // namespace dco::ipc::testing
