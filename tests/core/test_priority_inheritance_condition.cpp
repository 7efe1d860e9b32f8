#include "dco/core/priority_inheritance_condition.hpp"

#include <atomic>
#include <chrono>
#include <mutex>
#include <stop_token>
#include <thread>

#include <gtest/gtest.h>

namespace dco {
namespace {

using namespace std::chrono_literals;
using Lock = PriorityInheritanceCondition::Lock;

TEST(PriorityInheritanceCondition, ANotifyWakesAWaiterWhosePredicateHolds) {
  PriorityInheritanceMutex m;
  PriorityInheritanceCondition c;
  bool ready = false;
  std::thread waiter([&] {
    Lock lock(m);
    c.wait(lock, [&] { return ready; });
    EXPECT_TRUE(ready);
  });
  std::this_thread::sleep_for(10ms);
  {
    std::lock_guard lock(m);
    ready = true;
  }
  c.notify_all();
  waiter.join();
}

TEST(PriorityInheritanceCondition, ADeadlineEndsTheWaitWithThePredicatesValue) {
  PriorityInheritanceMutex m;
  PriorityInheritanceCondition c;
  Lock lock(m);
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_FALSE(c.wait_for(lock, 30ms, [] { return false; }));
  EXPECT_GE(std::chrono::steady_clock::now() - t0, 30ms);
  EXPECT_TRUE(lock.owns_lock());
  EXPECT_TRUE(c.wait_for(lock, 1h, [] { return true; }));  // no wait when it holds
  // A deadline already past, and one too far to represent, still answer.
  EXPECT_FALSE(c.wait_until(lock, std::chrono::steady_clock::time_point{}, [] { return false; }));
  bool flag = false;
  std::thread other([&] {
    std::this_thread::sleep_for(10ms);
    {
      std::lock_guard g(m);
      flag = true;
    }
    c.notify_one();
  });
  EXPECT_TRUE(c.wait_for(lock, std::chrono::hours(24 * 365 * 1000), [&] { return flag; }));
  other.join();
}

TEST(PriorityInheritanceCondition, AStopRequestEndsAWaitThatNothingElseWouldEnd) {
  PriorityInheritanceMutex m;
  PriorityInheritanceCondition c;
  // Many rounds, the request at varying moments: one that falls between the waiter's test and
  // its sleep must wake it too.
  for (int round = 0; round < 2000; ++round) {
    std::stop_source stop;
    std::atomic<bool> returned{false};
    bool result = true;
    std::thread waiter([&] {
      Lock lock(m);
      result = (round % 2 == 0)
                   ? c.wait(lock, stop.get_token(), [] { return false; })
                   : c.wait_until(lock, stop.get_token(), std::chrono::steady_clock::now() + 1h,
                                  [] { return false; });
      EXPECT_TRUE(lock.owns_lock());
      returned = true;
    });
    if (round % 3 == 1) std::this_thread::yield();
    if (round % 3 == 2) std::this_thread::sleep_for(std::chrono::microseconds(50));
    stop.request_stop();
    const auto t0 = std::chrono::steady_clock::now();
    while (!returned && std::chrono::steady_clock::now() - t0 < 5s) std::this_thread::yield();
    ASSERT_TRUE(returned) << "round " << round << ": the stop request was lost";
    waiter.join();
    EXPECT_FALSE(result);
  }
}

TEST(PriorityInheritanceCondition, AStopRequestedBeforeTheWaitReturnsThePredicate) {
  PriorityInheritanceMutex m;
  PriorityInheritanceCondition c;
  std::stop_source stop;
  stop.request_stop();
  Lock lock(m);
  EXPECT_FALSE(c.wait(lock, stop.get_token(), [] { return false; }));
  EXPECT_TRUE(c.wait(lock, stop.get_token(), [] { return true; }));
  EXPECT_TRUE(lock.owns_lock());
}

// The stop request's wake-up only tries the lock: a waiter that holds it while it leaves (its
// predicate came true as the request came) does not deadlock with the requesting thread, which
// waits in request_stop for the callback.
TEST(PriorityInheritanceCondition, AWaiterLeavingAsTheStopComesDoesNotDeadlock) {
  PriorityInheritanceMutex m;
  PriorityInheritanceCondition c;
  for (int round = 0; round < 500; ++round) {
    std::stop_source stop;
    bool ready = false;
    std::thread waiter([&] {
      Lock lock(m);
      EXPECT_TRUE(c.wait(lock, stop.get_token(), [&] { return ready; }));
      std::this_thread::sleep_for(std::chrono::microseconds(round % 7 * 20));
    });
    {
      std::lock_guard lock(m);
      ready = true;
    }
    c.notify_all();
    if (round % 2 == 0) std::this_thread::yield();
    stop.request_stop();
    waiter.join();
  }
}

}  // namespace
}  // namespace dco
