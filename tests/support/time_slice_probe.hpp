#pragma once

#include <cstdint>
#include <thread>

#include "dco/core/time_slice.hpp"

namespace dco::testing {

// Sets the calling thread's time slice to `ns` whatever it was (request_time_slice only ever
// shortens it), keeping its policy and nice value, and checks that the kernel kept it. A test
// thread inherits its creator's slice, so a test that checks a request starts its thread from a
// known, longer one.
inline bool set_time_slice(std::uint64_t ns) {
  SchedAttr a, b;
  return thread_sched_attr(0, a) && dco::set_time_slice(a, ns) && thread_sched_attr(0, b) &&
         b.sched_runtime == ns;
}

// Whether this kernel keeps and reports a time slice that a normal thread asks for (Linux 6.12+),
// tried on a thread of its own.
inline bool kernel_keeps_time_slices() {
  bool kept = false;
  std::thread([&] { kept = set_time_slice(300'000) && set_time_slice(400'000); }).join();
  return kept;
}

}  // namespace dco::testing
