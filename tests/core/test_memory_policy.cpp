#include "dco/core/memory_policy.hpp"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <thread>

#include <gtest/gtest.h>

namespace dco {
namespace {

long minor_faults() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_minflt;
}

// What a DIS call does to the heap: sixteen 1 MiB working buffers written and freed.
void frame_of_buffers() {
  void* buffers[16];
  for (void*& b : buffers) {
    b = std::malloc(1 << 20);
    std::memset(b, 1, 1 << 20);
  }
  for (void* b : buffers) std::free(b);
}

// Page faults per frame once warm, on the calling thread.
long faults_per_frame() {
  frame_of_buffers();
  frame_of_buffers();
  const long before = minor_faults();
  constexpr int kFrames = 8;
  for (int i = 0; i < kFrames; ++i) frame_of_buffers();
  return (minor_faults() - before) / kFrames;
}

// Runs the frames in a child process (the policy is process-wide), on its main thread and on a
// thread of its own (another malloc arena); returns the larger of the two per-frame counts.
long faults_in_child(bool retain) {
  const pid_t pid = fork();
  if (pid == 0) {
    if (retain && !retain_freed_memory()) _exit(254);
    long worst = faults_per_frame();
    long on_thread = 0;
    std::thread([&] { on_thread = faults_per_frame(); }).join();
    worst = std::max(worst, on_thread);
    _exit(static_cast<int>(std::min(worst / 64, 253L)));  // in units of 64 faults
  }
  int status = 0;
  waitpid(pid, &status, 0);
  EXPECT_TRUE(WIFEXITED(status));
  return 64L * WEXITSTATUS(status);
}

TEST(MemoryPolicy, FreedBuffersAreReusedWithoutFaultingTheirPagesInAgain) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "the sanitizer runtime owns the allocator";
#endif
  const long pages_per_frame = 16 * (1 << 20) / sysconf(_SC_PAGESIZE);
  const long retained = faults_in_child(true);
  ASSERT_NE(retained, 64L * 254) << "the C library has no setting to keep freed memory";
  // A few pages of bookkeeping at most; without the policy glibc gives the buffers back to the
  // kernel and the next frame faults in nearly all of them again (printed for the record).
  EXPECT_LT(retained, pages_per_frame / 16);
  const long released = faults_in_child(false);
  std::printf("page faults per frame of %ld pages: %ld retained, about %ld with the defaults\n",
              pages_per_frame, retained, released);
}

}  // namespace
}  // namespace dco
