#pragma once

// A mutex that lends its holder the priority of a real-time thread waiting for it
// (PTHREAD_PRIO_INHERIT). dcod's release thread runs at SCHED_FIFO and shares the runtime's
// state, the publisher, the frame numbers and the LCM sender's queue with normal threads: one of
// them preempted while holding such a lock, with the stage threads keeping every CPU busy, would
// hold a release up for a scheduler slice. Usable with std::lock_guard and std::unique_lock; a
// thread waits on it with PriorityInheritanceCondition.

#include <pthread.h>

#include <cerrno>
#include <system_error>

namespace dco {

class PriorityInheritanceMutex {
 public:
  PriorityInheritanceMutex() {
    pthread_mutexattr_t attr;
    pthread_mutexattr_init(&attr);
    pthread_mutexattr_setprotocol(&attr, PTHREAD_PRIO_INHERIT);
    int err = pthread_mutex_init(&mutex_, &attr);
    pthread_mutexattr_destroy(&attr);
    // Where the kernel has no priority-inheriting futexes (glibc's ENOTSUP; emulators) the mutex
    // is a plain one.
    if (err == ENOTSUP) err = pthread_mutex_init(&mutex_, nullptr);
    if (err != 0) throw std::system_error(err, std::generic_category(), "pthread_mutex_init");
  }
  ~PriorityInheritanceMutex() { pthread_mutex_destroy(&mutex_); }
  PriorityInheritanceMutex(const PriorityInheritanceMutex&) = delete;
  PriorityInheritanceMutex& operator=(const PriorityInheritanceMutex&) = delete;

  void lock() {
    if (const int err = pthread_mutex_lock(&mutex_); err != 0)
      throw std::system_error(err, std::generic_category(), "pthread_mutex_lock");
  }
  bool try_lock() { return pthread_mutex_trylock(&mutex_) == 0; }
  void unlock() { pthread_mutex_unlock(&mutex_); }
  pthread_mutex_t* native_handle() { return &mutex_; }

 private:
  pthread_mutex_t mutex_;
};

}  // namespace dco
