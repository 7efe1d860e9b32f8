#pragma once

#include <sched.h>

namespace dco::testing {

// Restricts the calling thread (and the processes it starts) to some of its CPUs for the scope,
// then gives its mask back.
class CpuScope {
 public:
  // The first `count` CPUs of its mask; 0: the one it runs on now.
  explicit CpuScope(int count) {
    CPU_ZERO(&saved_);
    sched_getaffinity(0, sizeof(saved_), &saved_);
    cpu_set_t some;
    CPU_ZERO(&some);
    int taken = 0;
    if (count == 0) {
      CPU_SET(sched_getcpu(), &some);
      taken = count = 1;
    }
    for (int cpu = 0; cpu < CPU_SETSIZE && taken < count; ++cpu)
      if (CPU_ISSET(cpu, &saved_)) {
        CPU_SET(cpu, &some);
        ++taken;
      }
    ok_ = taken == count && sched_setaffinity(0, sizeof(some), &some) == 0;
  }
  ~CpuScope() { sched_setaffinity(0, sizeof(saved_), &saved_); }
  CpuScope(const CpuScope&) = delete;
  CpuScope& operator=(const CpuScope&) = delete;
  bool ok() const { return ok_; }

 private:
  cpu_set_t saved_;
  bool ok_ = false;
};

// The CPU the calling thread is on, for the scope.
class OneCpu : public CpuScope {
 public:
  OneCpu() : CpuScope(0) {}
};

}  // namespace dco::testing
