#pragma once

// A condition variable for PriorityInheritanceMutex: a pthread condition on the mutex's own
// pthread mutex, with std::condition_variable_any's predicate, deadline and stop-token waits.
// std::condition_variable_any guards each wait and notify with a plain mutex of its own: a normal
// thread preempted inside its wait while holding that one would make a SCHED_FIFO notifier wait
// for it without lending it any priority. Here a notify takes no lock.

#include <pthread.h>
#include <time.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <stop_token>
#include <system_error>
#include <thread>

#include "dco/core/priority_inheritance_mutex.hpp"

namespace dco {

class PriorityInheritanceCondition {
 public:
  using Lock = std::unique_lock<PriorityInheritanceMutex>;
  using Clock = std::chrono::steady_clock;  // CLOCK_MONOTONIC

  PriorityInheritanceCondition() {
    pthread_condattr_t attr;
    pthread_condattr_init(&attr);
    pthread_condattr_setclock(&attr, CLOCK_MONOTONIC);
    const int err = pthread_cond_init(&cond_, &attr);
    pthread_condattr_destroy(&attr);
    if (err != 0) throw std::system_error(err, std::generic_category(), "pthread_cond_init");
  }
  ~PriorityInheritanceCondition() { pthread_cond_destroy(&cond_); }
  PriorityInheritanceCondition(const PriorityInheritanceCondition&) = delete;
  PriorityInheritanceCondition& operator=(const PriorityInheritanceCondition&) = delete;

  void notify_one() noexcept { pthread_cond_signal(&cond_); }
  void notify_all() noexcept { pthread_cond_broadcast(&cond_); }

  void wait(Lock& lock) { check(pthread_cond_wait(&cond_, lock.mutex()->native_handle())); }
  // False when `until` passed first.
  bool wait_until(Lock& lock, Clock::time_point until) {
    const timespec at = to_timespec(until);
    const int err = pthread_cond_timedwait(&cond_, lock.mutex()->native_handle(), &at);
    if (err == ETIMEDOUT) return false;
    check(err);
    return true;
  }

  template <class Predicate>
  void wait(Lock& lock, Predicate&& pred) {
    while (!pred()) wait(lock);
  }
  template <class Predicate>
  bool wait_until(Lock& lock, Clock::time_point until, Predicate&& pred) {
    while (!pred())
      if (!wait_until(lock, until)) return pred();
    return true;
  }
  template <class Rep, class Period, class Predicate>
  bool wait_for(Lock& lock, std::chrono::duration<Rep, Period> wait, Predicate&& pred) {
    return wait_until(lock, deadline(wait), pred);
  }

  // As std::condition_variable_any's: until pred() holds or a stop is requested; returns pred().
  template <class Predicate>
  bool wait(Lock& lock, std::stop_token stop, Predicate&& pred) {
    return wait_stoppable(lock, stop, nullptr, pred);
  }
  template <class Predicate>
  bool wait_until(Lock& lock, std::stop_token stop, Clock::time_point until, Predicate&& pred) {
    return wait_stoppable(lock, stop, &until, pred);
  }

 private:
  static void check(int err) {
    if (err != 0) throw std::system_error(err, std::generic_category(), "pthread_cond_wait");
  }
  template <class Rep, class Period>
  static Clock::time_point deadline(std::chrono::duration<Rep, Period> wait) {
    // Longer than a year is "no deadline" here, and cannot overflow the clock.
    constexpr Clock::duration kLongest = std::chrono::hours(24 * 365);
    const bool longest = std::chrono::duration<double>(wait) >= kLongest;
    return Clock::now() + (longest ? kLongest : std::chrono::ceil<Clock::duration>(wait));
  }
  static timespec to_timespec(Clock::time_point t) {
    // A century past the clock's zero stands for "never": it fits time_t everywhere.
    constexpr std::int64_t kNever = std::int64_t{100} * 365 * 24 * 3600;
    const std::int64_t ns =
        std::chrono::duration_cast<std::chrono::nanoseconds>(
            std::min(t.time_since_epoch(),
                     std::chrono::duration_cast<Clock::duration>(std::chrono::seconds(kNever))))
            .count();
    timespec at{};
    at.tv_sec = static_cast<time_t>(ns < 0 ? 0 : ns / 1'000'000'000);
    at.tv_nsec = static_cast<long>(ns < 0 ? 0 : ns % 1'000'000'000);
    return at;
  }

  // The stop request wakes the waiters from the requesting thread, under the lock, so that one
  // made between the waiter's test and its sleep is not missed. That thread only tries the lock:
  // the waiter holds it while it leaves (and its callback's removal waits for a callback running
  // elsewhere), and then needs no wake-up.
  template <class Predicate>
  bool wait_stoppable(Lock& lock, const std::stop_token& stop, const Clock::time_point* until,
                      Predicate& pred) {
    if (pred()) return true;
    std::atomic<bool> left{false};
    const std::thread::id waiter = std::this_thread::get_id();
    PriorityInheritanceMutex& mutex = *lock.mutex();
    const std::stop_callback wake(stop, [&] {
      // Run at its registration, the request came first: the loop below sees it.
      if (std::this_thread::get_id() == waiter) return;
      while (!mutex.try_lock()) {
        if (left.load(std::memory_order_acquire)) return;
        std::this_thread::yield();
      }
      notify_all();
      mutex.unlock();
    });
    bool result = false;
    for (;;) {
      if (stop.stop_requested()) {
        result = pred();
        break;
      }
      if (until != nullptr) {
        if (!wait_until(lock, *until)) {
          result = pred();
          break;
        }
      } else {
        wait(lock);
      }
      if (pred()) {
        result = true;
        break;
      }
    }
    left.store(true, std::memory_order_release);
    return result;
  }

  pthread_cond_t cond_;
};

}  // namespace dco
