#pragma once

// Names a thread, so top -H, perf and gdb tell dco's threads apart. Linux keeps 15 characters; a
// longer name is cut to them. A name that cannot be set costs nothing but the name.

#include <pthread.h>

#include <algorithm>
#include <cstring>

namespace dco {

inline void name_thread(pthread_t thread, const char* name) {
  char kept[16] = {};
  std::memcpy(kept, name, std::min(std::strlen(name), sizeof kept - 1));
  pthread_setname_np(thread, kept);
}

inline void name_this_thread(const char* name) {
  name_thread(pthread_self(), name);
}

}  // namespace dco
