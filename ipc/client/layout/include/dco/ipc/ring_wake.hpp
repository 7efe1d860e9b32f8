#pragma once

// The ring's wake-up: the writer bumps RingHeader::wake after each publish and on close and wakes
// every process sleeping on it. A shared (not process-private) futex, because readers live in
// other processes; FUTEX_WAIT only reads the word, so it works on the readers' read-only mapping.

#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>
#include <ctime>

namespace dco::ipc::layout {

// Sleeps while `word` still holds `seen`, at most `timeout_ns`. Returns early on a wake-up, a
// change of the word, a signal or a spurious wake; the caller re-checks what it waits for.
inline void wait_for_change(const std::atomic<std::uint32_t>& word, std::uint32_t seen,
                            std::int64_t timeout_ns) {
  if (timeout_ns <= 0) return;
  const timespec ts{static_cast<time_t>(timeout_ns / 1'000'000'000),
                    static_cast<long>(timeout_ns % 1'000'000'000)};
  // std::atomic<std::uint32_t> is a plain 32-bit word (static_assert in ring_layout.hpp).
  syscall(SYS_futex, reinterpret_cast<const std::uint32_t*>(&word), FUTEX_WAIT, seen, &ts, nullptr,
          0);
}

// Changes `word` and wakes every sleeper. One system call per publish, whether or not anyone
// sleeps: readers cannot register (their mapping is read-only), and at camera rates it costs
// about a microsecond.
inline void change_and_wake(std::atomic<std::uint32_t>& word) {
  word.fetch_add(1, std::memory_order_release);
  syscall(SYS_futex, reinterpret_cast<std::uint32_t*>(&word), FUTEX_WAKE, INT32_MAX, nullptr,
          nullptr, 0);
}

}  // namespace dco::ipc::layout
