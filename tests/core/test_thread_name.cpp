#include "dco/core/thread_name.hpp"

#include <gtest/gtest.h>
#include <pthread.h>

#include <chrono>
#include <string>
#include <thread>

namespace dco {
namespace {

std::string name_seen_after(const char* name) {
  std::string seen;
  std::thread([&] {
    name_this_thread(name);
    char buffer[32] = {};
    pthread_getname_np(pthread_self(), buffer, sizeof buffer);
    seen = buffer;
  }).join();
  return seen;
}

TEST(ThreadName, NamesTheCallingThread) {
  EXPECT_EQ(name_seen_after("dco-test"), "dco-test");
}

TEST(ThreadName, NamesAnotherThreadByItsHandle) {
  std::string seen;
  std::thread named([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    char buffer[32] = {};
    pthread_getname_np(pthread_self(), buffer, sizeof buffer);
    seen = buffer;
  });
  name_thread(named.native_handle(), "dco-other");
  named.join();
  EXPECT_EQ(seen, "dco-other");
}

TEST(ThreadName, ALongNameIsCutToTheFifteenCharactersLinuxKeeps) {
  EXPECT_EQ(name_seen_after("dco-a-name-far-too-long"), "dco-a-name-far-");
}

}  // namespace
}  // namespace dco
