#pragma once

// Reader processes for the multi-process tests: spawning dco_ipc_reader, collecting its one-line
// report, and the writer-side pattern frames they check.

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "ipc_test_support.hpp"

namespace dco::ipc::testing {

constexpr int kFrameWidth = 256;
constexpr int kFrameHeight = 144;

struct Child {
  std::string name;
  pid_t pid = -1;
  int out = -1;  // the child's stdout
  int status = 0;
  bool exited = false;
  std::string output;
};

inline Child spawn(const std::string& name, const std::vector<std::string>& args) {
  int fds[2];
  EXPECT_EQ(pipe(fds), 0);
  std::vector<char*> argv;
  argv.push_back(const_cast<char*>(DCO_IPC_READER_EXE));
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    dup2(fds[1], STDOUT_FILENO);
    close(fds[0]);
    close(fds[1]);
    execv(argv[0], argv.data());
    _exit(127);
  }
  close(fds[1]);
  fcntl(fds[0], F_SETFL, O_NONBLOCK);
  Child c;
  c.name = name;
  c.pid = pid;
  c.out = fds[0];
  return c;
}

inline void drain(Child& c) {
  char buf[512];
  ssize_t n = 0;
  while ((n = read(c.out, buf, sizeof(buf))) > 0) c.output.append(buf, static_cast<std::size_t>(n));
}

// Reaps a finished child without waiting; true once it is gone.
inline bool poll_exit(Child& c) {
  if (c.exited) return true;
  drain(c);
  if (waitpid(c.pid, &c.status, WNOHANG) != c.pid) return false;
  drain(c);
  close(c.out);
  c.exited = true;
  return true;
}

inline long field(const std::string& line, const std::string& key) {
  std::istringstream in(line);
  std::string k;
  long v = -1;
  while (in >> k) {
    if (k == key) {
      in >> v;
      return v;
    }
  }
  return -1;
}

class PatternSource {
 public:
  PatternSource() : depth_(kFrameWidth, kFrameHeight), image_(kFrameWidth, kFrameHeight) {}
  void fill(std::uint64_t seq) {
    for (int y = 0; y < kFrameHeight; ++y)
      for (int x = 0; x < kFrameWidth; ++x) {
        const auto ux = static_cast<std::uint32_t>(x);
        const auto uy = static_cast<std::uint32_t>(y);
        depth_.at(x, y) = pattern_depth(seq, ux, uy);
        image_.at(x, y) = pattern_image(seq, ux, uy);
      }
  }
  ImageView<const float> depth() const { return depth_.cview(); }
  ImageView<const std::uint8_t> image() const { return image_.cview(); }

 private:
  Image<float> depth_;
  Image<std::uint8_t> image_;
};

// Reader processes keep reading while the writer is restarted `cycles - 1` times (a clean stop,
// then a new ring with a new session id and another slot count). Every reader must exit cleanly,
// accept no torn frame, and the steady ones must have read from every session.
inline void run_restarts(int cycles, std::chrono::milliseconds per_cycle, int readers) {
  TempDir dir;
  const auto path = dir.path() / "depth.shm";
  RingOptions o;
  o.width = kFrameWidth;
  o.height = kFrameHeight;
  o.image_channels = 1;
  o.slot_count = 3;
  auto writer = std::make_unique<RingWriter>(path, o);
  const std::string duration = std::to_string((cycles * per_cycle).count() + 300);
  const char* modes[] = {"view", "copy", "slow"};
  std::vector<Child> kids;
  for (int r = 0; r < readers; ++r) {
    const std::string mode = modes[r % 3];
    kids.push_back(
        spawn(mode + std::to_string(r), {"--path", path.string(), "--mode", mode, "--row-us", "40",
                                         "--duration-ms", duration, "--follow-restarts", "1"}));
  }
  PatternSource source;
  std::uint64_t seq = 0;
  const auto publish_for = [&](std::chrono::milliseconds span) {
    const auto end = std::chrono::steady_clock::now() + span;
    while (std::chrono::steady_clock::now() < end) {
      source.fill(++seq);
      writer->write(source.depth(), source.image(), {.frame_seq = seq});
      std::this_thread::sleep_for(std::chrono::milliseconds(4));
    }
  };
  for (int c = 0; c < cycles; ++c) {
    if (c > 0) {
      writer.reset();
      std::this_thread::sleep_for(std::chrono::milliseconds(30));
      o.slot_count = 3 + c % 3;
      writer = std::make_unique<RingWriter>(path, o);
    }
    publish_for(per_cycle);
  }
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  for (;;) {
    bool all = true;
    for (auto& k : kids) all = poll_exit(k) && all;
    if (all) break;
    ASSERT_LT(std::chrono::steady_clock::now(), give_up) << "readers did not finish";
    publish_for(std::chrono::milliseconds(20));
  }
  for (auto& k : kids) {
    SCOPED_TRACE(k.name + ": " + k.output);
    ASSERT_TRUE(WIFEXITED(k.status) && WEXITSTATUS(k.status) == 0);
    EXPECT_EQ(field(k.output, "torn_accepted"), 0);
    if (k.name.rfind("slow", 0) != 0) {
      EXPECT_EQ(field(k.output, "sessions"), cycles);
    }
  }
}

}  // namespace dco::ipc::testing
