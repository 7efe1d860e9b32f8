#pragma once

// Running shell commands from tests, and the private network namespace that every LCM udpm test
// runs in (lo up with a multicast route), so no multicast ever leaves the machine.

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <string>

namespace dco::testing {

struct CommandResult {
  int status = -1;
  std::string output;  // stdout and stderr
};

// Runs a command to completion; its exit status and everything it printed.
inline CommandResult run_command(const std::string& command) {
  CommandResult r;
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (p == nullptr) return r;
  char buf[512];
  while (std::fgets(buf, sizeof buf, p) != nullptr) r.output += buf;
  const int status = pclose(p);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
  return r;
}

// Root gets a network namespace directly; anyone else through a user namespace.
inline std::string unshare_command() {
  return geteuid() == 0 ? "unshare -n" : "unshare -rn";
}
// Inside the namespace: without the multicast route LCM udpm refuses to start.
inline const char* const kNetnsSetup = "ip link set lo up && ip route add 224.0.0.0/4 dev lo";

// Empty when a private network namespace can be made here, else why not.
inline std::string private_network_problem() {
  const std::string command = unshare_command() + " sh -c '" + kNetnsSetup + "'";
  const CommandResult probe = run_command(command);
  return probe.status == 0 ? std::string() : "`" + command + "` failed: " + probe.output;
}

}  // namespace dco::testing
