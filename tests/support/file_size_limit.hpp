#pragma once

// A write that runs out of disk, for tests: the call runs in a child process whose files may not
// grow past a limit (RLIMIT_FSIZE, with SIGXFSZ ignored so that writes fail instead of killing).

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <exception>
#include <functional>

namespace dco::testing {

// The child's exit status: kWriteThrew when `write` threw, 0 when it returned; -1 when the child
// could not start or did not exit.
inline constexpr int kWriteThrew = 3;
inline int status_of_write_past_file_limit(rlim_t bytes, const std::function<void()>& write) {
  const pid_t child = fork();
  if (child < 0) return -1;
  if (child == 0) {
    signal(SIGXFSZ, SIG_IGN);
    const rlimit limit{bytes, bytes};
    setrlimit(RLIMIT_FSIZE, &limit);
    try {
      write();
    } catch (const std::exception&) {
      _exit(kWriteThrew);
    }
    _exit(0);
  }
  int status = 0;
  if (waitpid(child, &status, 0) != child || !WIFEXITED(status)) return -1;
  return WEXITSTATUS(status);
}

}  // namespace dco::testing
