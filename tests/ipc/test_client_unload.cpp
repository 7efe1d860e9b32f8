// An app that loads libdco-client as a plugin (dlopen) and drops it (dlclose): the library must
// leave the process. A GNU unique symbol in it would pin it for the process's lifetime.
#include <dlfcn.h>

#include <fstream>
#include <string>

#include <gtest/gtest.h>

namespace {

bool mapped(const std::string& file) {
  std::ifstream maps("/proc/self/maps");
  std::string line;
  while (std::getline(maps, line))
    if (line.find(file) != std::string::npos) return true;
  return false;
}

TEST(ClientLibrary, UnloadsOnDlclose) {
  const std::string lib = DCO_CLIENT_LIBRARY;
  ASSERT_FALSE(mapped(lib)) << "this test must not link the library itself";
  void* handle = dlopen(lib.c_str(), RTLD_NOW | RTLD_LOCAL);
  ASSERT_NE(handle, nullptr) << dlerror();
  EXPECT_NE(dlsym(handle, "dco_client_open"), nullptr);
  EXPECT_TRUE(mapped(lib));
  // A failed call leaves its message in thread-local storage of the library's: that must not
  // pin the library to this thread.
  using OptionsInit = void (*)(void*);
  using Open = int (*)(const void*, void**);
  using LastError = const char* (*)();
  alignas(16) unsigned char options[512] = {};
  void* client = nullptr;
  reinterpret_cast<OptionsInit>(dlsym(handle, "dco_client_options_init"))(options);
  EXPECT_NE(reinterpret_cast<Open>(dlsym(handle, "dco_client_open"))(options, &client), 0);
  EXPECT_NE(std::string(reinterpret_cast<LastError>(dlsym(handle, "dco_client_last_error"))()), "");
  ASSERT_EQ(dlclose(handle), 0);
  EXPECT_FALSE(mapped(lib)) << "dlclose left the library mapped";
}

}  // namespace
