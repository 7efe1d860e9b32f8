#pragma once

// A mutex that lends its holder the priority of a real-time thread waiting for it
// (PTHREAD_PRIO_INHERIT). dcod's release thread runs at SCHED_FIFO and shares the publisher with
// normal threads: one of them preempted while holding it, with the stage threads keeping every
// CPU busy, would hold a release up for a scheduler slice. Usable with std::lock_guard.

#include <pthread.h>

#include <system_error>

namespace dco {

class PriorityInheritanceMutex {
 public:
  PriorityInheritanceMutex() {
    pthread_mutexattr_t attr;
    pthread_mutexattr_init(&attr);
    // Where the protocol is not supported the mutex is a plain one.
    pthread_mutexattr_setprotocol(&attr, PTHREAD_PRIO_INHERIT);
    const int err = pthread_mutex_init(&mutex_, &attr);
    pthread_mutexattr_destroy(&attr);
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

 private:
  pthread_mutex_t mutex_;
};

}  // namespace dco
