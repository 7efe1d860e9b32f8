#include "dco/core/priority_inheritance_mutex.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>

namespace dco {
namespace {

// The kernel's priority of a thread as it runs now (field 18 of its stat line): 20 for a normal
// thread at nice 0, -1 - P for SCHED_FIFO priority P, boosts included.
int effective_priority(pid_t tid) {
  std::ifstream in("/proc/self/task/" + std::to_string(tid) + "/stat");
  std::string line;
  std::getline(in, line);
  // Past the command name in parentheses, which may hold spaces.
  std::istringstream fields(line.substr(line.rfind(')') + 2));
  std::string field;
  for (int i = 3; i <= 18; ++i) fields >> field;
  return std::stoi(field);
}

TEST(PriorityInheritanceMutex, LocksAsAMutex) {
  PriorityInheritanceMutex m;
  {
    std::lock_guard lock(m);
    std::thread other([&] { EXPECT_FALSE(m.try_lock()); });
    other.join();
  }
  EXPECT_TRUE(m.try_lock());
  m.unlock();
}

// A normal thread holding the mutex runs at the priority of a SCHED_FIFO thread waiting for it.
TEST(PriorityInheritanceMutex, AWaitingRealTimeThreadLendsItsPriority) {
  PriorityInheritanceMutex m;
  const auto holder = static_cast<pid_t>(syscall(SYS_gettid));
  const int base = effective_priority(holder);  // 20 + its nice value
  ASSERT_GE(base, 0) << "this test runs on a normal thread";
  m.lock();
  std::atomic<int> started{-1};
  std::thread waiter([&] {
    const sched_param p{1};
    started = pthread_setschedparam(pthread_self(), SCHED_FIFO, &p);
    if (started != 0) return;
    std::lock_guard lock(m);
  });
  while (started < 0) std::this_thread::yield();
  if (started != 0) {
    m.unlock();
    waiter.join();
    GTEST_SKIP() << "SCHED_FIFO refused here (no CAP_SYS_NICE or RLIMIT_RTPRIO)";
  }
  int boosted = base;
  for (int i = 0; i < 200 && boosted == base; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    boosted = effective_priority(holder);
  }
  m.unlock();
  waiter.join();
  EXPECT_EQ(boosted, -2) << "the holder was not lent SCHED_FIFO 1";
  EXPECT_EQ(effective_priority(holder), base);
}

}  // namespace
}  // namespace dco
