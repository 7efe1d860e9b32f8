// "A spoofed DCO_DEPTH message from another process cannot make a client accept depth that the
// daemon did not write": the daemon, a spoofing process and a reader on a real udpm bus, inside a
// private network namespace so no multicast leaves the machine (see lcm_spoof_scenario.cpp).

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "support/temp_dir.hpp"

namespace dco::ipc::testing {
namespace {

struct CommandResult {
  int status = -1;
  std::string output;
};

CommandResult run(const std::string& command) {
  CommandResult r;
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (p == nullptr) return r;
  char buf[512];
  while (std::fgets(buf, sizeof(buf), p) != nullptr) r.output += buf;
  const int status = pclose(p);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
  return r;
}

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

// Root gets a network namespace directly; anyone else through a user namespace.
std::string unshare_command() {
  return geteuid() == 0 ? "unshare -n" : "unshare -rn";
}

TEST(LcmSpoof, ForgedDescriptorsFromAnotherProcessAreNeverAccepted) {
  const std::string unshare = unshare_command();
  const std::string setup = "ip link set lo up && ip route add 224.0.0.0/4 dev lo";
  const CommandResult probe = run(unshare + " sh -c '" + setup + "'");
  if (probe.status != 0)
    GTEST_SKIP() << "cannot set up a private network namespace (`" << unshare << " sh -c '" << setup
                 << "'` failed: " << probe.output << "); the udpm test never runs outside one";
  dco::testing::TempDir dir;
  constexpr int kFrames = 120;
  const std::string url = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304";
  // lo up with a multicast route: without the route LCM refuses to start.
  const CommandResult r =
      run(unshare + " sh -c '" + setup + " && exec \"$0\" \"$@\"' " + DCO_LCM_SPOOF_SCENARIO_EXE +
          " " + dir.path().string() + " '" + url + "' " + std::to_string(kFrames) + " 4000");
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
