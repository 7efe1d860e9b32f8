#pragma once

// The time slice a thread asks the scheduler for (sched_setattr's sched_runtime), which Linux 6.12
// and later honour for normal threads without privileges; older kernels ignore it. And real-time
// priority, for the threads that must wake on time. Header-only and without dco_core's
// dependencies, so libdco-client uses it too.

#include <pthread.h>
#include <sched.h>
#include <sys/syscall.h>
#include <sys/types.h>
#include <unistd.h>

#include <cstdint>

namespace dco {

// struct sched_attr of sched_setattr(2), which glibc does not wrap.
struct SchedAttr {
  std::uint32_t size;
  std::uint32_t sched_policy;
  std::uint64_t sched_flags;
  std::int32_t sched_nice;
  std::uint32_t sched_priority;
  std::uint64_t sched_runtime, sched_deadline, sched_period;
};
static_assert(sizeof(SchedAttr) == 48);

// The scheduling attributes of thread `tid` (0: the calling thread); false where the kernel has
// no sched_getattr.
inline bool thread_sched_attr(pid_t tid, SchedAttr& out) {
  out = {};
  return syscall(SYS_sched_getattr, tid, &out, sizeof out, 0) == 0;
}

// Gives the calling thread, whose attributes are `attr`, a time slice of `ns` and keeps its
// policy and nice value; true when the kernel accepted it.
inline bool set_time_slice(SchedAttr attr, std::uint64_t ns) {
  attr.size = sizeof attr;
  // SCHED_FLAG_RESET_ON_FORK is part of the thread's policy (sched_setscheduler's
  // SCHED_RESET_ON_FORK): kept. The other flags ask for changes this call does not make.
  constexpr std::uint64_t kResetOnFork = 0x01;
  attr.sched_flags &= kResetOnFork;
  attr.sched_runtime = ns;
  return syscall(SYS_sched_setattr, 0, &attr, 0) == 0;
}

// Asks for a time slice of `ns` for the calling thread, keeping its policy and nice value.
// Real-time and deadline threads, and threads that already asked for a slice this short, are left
// alone. True when a request was made and accepted.
inline bool request_time_slice(std::uint64_t ns) {
  SchedAttr attr;
  if (!thread_sched_attr(0, attr)) return false;
  if (attr.sched_policy != SCHED_OTHER && attr.sched_policy != SCHED_BATCH) return false;
  if (attr.sched_runtime != 0 && attr.sched_runtime <= ns) return false;
  return set_time_slice(attr, ns);
}

// Moves the calling thread to SCHED_FIFO at `priority` (1-99). A process may where it has
// CAP_SYS_NICE or an RLIMIT_RTPRIO of at least `priority`; true when the kernel agreed.
inline bool request_fifo_priority(int priority) {
  sched_param param{};
  param.sched_priority = priority;
  return pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) == 0;
}

}  // namespace dco
