#pragma once

// Runs dcod as a child process the way systemd would: with $NOTIFY_SOCKET bound by the test (an
// AF_UNIX datagram socket that collects READY/STATUS/WATCHDOG/... messages), optionally
// $WATCHDOG_USEC/$WATCHDOG_PID, stderr captured to a file, and optionally inside a private
// network namespace (lo up with a multicast route) so LCM udpm never leaves the machine.

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "support/commands.hpp"

namespace dco::testing {

using SteadyClock = std::chrono::steady_clock;

struct Notification {
  SteadyClock::time_point at;
  std::string text;
};

class NotifySocket {
 public:
  explicit NotifySocket(const std::filesystem::path& path) : path_(path) {
    fd_ = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, path.c_str(), sizeof(addr.sun_path) - 1);
    EXPECT_EQ(bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0) << path;
    // Reads all the time, like systemd: a full socket would block the daemon's sd_notify.
    reader_ = std::jthread([this](std::stop_token stop) {
      while (!stop.stop_requested()) {
        pollfd p{fd_, POLLIN, 0};
        if (poll(&p, 1, 20) > 0) drain();
      }
    });
  }
  ~NotifySocket() {
    reader_.request_stop();
    reader_.join();
    close(fd_);
  }

  const std::filesystem::path& path() const { return path_; }

  // Collects datagrams for up to `timeout` or until `done` says so.
  bool collect(std::chrono::milliseconds timeout,
               const std::function<bool(const std::vector<Notification>&)>& done) {
    const auto end = SteadyClock::now() + timeout;
    while (!done(messages())) {
      if (SteadyClock::now() >= end) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return true;
  }
  void drain() {
    char buf[4096];
    ssize_t n = 0;
    while ((n = recv(fd_, buf, sizeof buf, 0)) > 0) {
      std::lock_guard lock(mutex_);
      messages_.push_back({SteadyClock::now(), std::string(buf, static_cast<std::size_t>(n))});
    }
  }
  // Waits for a datagram containing `text` (a line such as "READY=1"); returns its time.
  std::optional<SteadyClock::time_point> wait_for(const std::string& text,
                                                  std::chrono::milliseconds timeout,
                                                  std::size_t from = 0) {
    std::optional<SteadyClock::time_point> at;
    collect(timeout, [&](const std::vector<Notification>& m) {
      for (std::size_t i = from; i < m.size(); ++i)
        if (m[i].text.find(text) != std::string::npos) {
          at = m[i].at;
          return true;
        }
      return false;
    });
    return at;
  }
  // Datagrams containing `text` among messages [from, to) in arrival order (to = -1: all so far).
  long count(const std::string& text, std::size_t from, std::size_t to = std::size_t(-1)) {
    const std::vector<Notification> m = messages();
    long n = 0;
    for (std::size_t i = from; i < std::min(to, m.size()); ++i)
      if (m[i].text.find(text) != std::string::npos) ++n;
    return n;
  }
  // A snapshot of everything received so far, in arrival order.
  std::vector<Notification> messages() {
    std::lock_guard lock(mutex_);
    return messages_;
  }

 private:
  std::filesystem::path path_;
  int fd_ = -1;
  std::mutex mutex_;
  std::vector<Notification> messages_;
  std::jthread reader_;
};

struct DcodOptions {
  std::vector<std::string> args;
  std::filesystem::path log;                // stderr goes here
  const NotifySocket* notify = nullptr;     // sets $NOTIFY_SOCKET
  std::chrono::microseconds watchdog{0};    // sets $WATCHDOG_USEC/$WATCHDOG_PID when > 0
  bool private_network = false;             // run inside unshare -n with lo multicast
  std::string network_setup = kNetnsSetup;  // what runs in that namespace before dcod
  std::vector<std::string> prefix;          // a command that execs dcod (setpriv)
};

class DcodProcess {
 public:
  explicit DcodProcess(const DcodOptions& o) : log_(o.log) {
    std::vector<std::string> argv;
    if (o.private_network) {
      std::istringstream words(unshare_command());
      for (std::string w; words >> w;) argv.push_back(w);
      argv.insert(argv.end(), {"sh", "-c", o.network_setup + " && exec \"$0\" \"$@\""});
    }
    argv.insert(argv.end(), o.prefix.begin(), o.prefix.end());
    argv.push_back(DCOD_EXE);
    argv.insert(argv.end(), o.args.begin(), o.args.end());
    pid_ = fork();
    if (pid_ == 0) {
      const int fd = open(o.log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
      if (fd >= 0) dup2(fd, STDERR_FILENO);
      if (o.notify) setenv("NOTIFY_SOCKET", o.notify->path().c_str(), 1);
      if (o.watchdog.count() > 0) {
        setenv("WATCHDOG_USEC", std::to_string(o.watchdog.count()).c_str(), 1);
        // unshare and sh exec into dcod, so this process's pid is dcod's.
        setenv("WATCHDOG_PID", std::to_string(getpid()).c_str(), 1);
      }
      std::vector<char*> cargv;
      for (auto& a : argv) cargv.push_back(a.data());
      cargv.push_back(nullptr);
      execvp(cargv[0], cargv.data());
      _exit(127);
    }
  }
  ~DcodProcess() {
    if (!exited_) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }

  pid_t pid() const { return pid_; }
  void signal(int sig) const { kill(pid_, sig); }

  // The exit status, or -1 if it is still running after `timeout` (or died from a signal: 128+n).
  int wait(std::chrono::milliseconds timeout) {
    const auto end = SteadyClock::now() + timeout;
    while (!exited_) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        exited_ = true;
        status_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        break;
      }
      if (SteadyClock::now() >= end) return -1;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return status_;
  }
  bool running() { return wait(std::chrono::milliseconds(0)) == -1; }
  std::string log() const {
    std::ifstream in(log_);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

 private:
  std::filesystem::path log_;
  pid_t pid_ = -1;
  bool exited_ = false;
  int status_ = -1;
};

}  // namespace dco::testing
