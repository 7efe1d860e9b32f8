#pragma once

// Heap allocation counting for a whole test binary, on every thread: global operator new (all
// its forms) and, outside sanitizer builds, aligned_alloc (dco::Image storage). A binary that
// links allocation_counter.cpp gets these replacements; counting is on only between start() and
// stop(), around the calls under test.

#include <atomic>

namespace dco::testing {

struct AllocationCounts {
  long new_calls = 0;            // operator new, any form
  long aligned_alloc_calls = 0;  // std::aligned_alloc (always 0 under a sanitizer)
  long total() const { return new_calls + aligned_alloc_calls; }
};

// A sanitizer's runtime owns aligned_alloc, so those calls cannot be counted there.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
inline constexpr bool kCountsAlignedAlloc = false;
#else
inline constexpr bool kCountsAlignedAlloc = true;
#endif

void start_counting_allocations();
AllocationCounts stop_counting_allocations();

// Keeps an allocation in a test from being optimised away.
extern std::atomic<const void*> allocation_sink;

}  // namespace dco::testing
