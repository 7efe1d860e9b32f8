#pragma once

// A private X server for the window tests, and a second X client that looks at a window as any
// other client would. No X header leaks out (its macros clash with GoogleTest's).

#include <sys/types.h>

#include <cstdint>
#include <string>
#include <vector>

namespace dco::compositor {

// An Xvfb of its own: it picks a free display number and says which on a pipe (-displayfd), so
// tests running side by side never collide.
class Xvfb {
 public:
  Xvfb();
  ~Xvfb();
  Xvfb(const Xvfb&) = delete;
  Xvfb& operator=(const Xvfb&) = delete;
  // Empty when Xvfb did not start (scripts/setup installs it).
  const std::string& name() const { return name_; }

 private:
  pid_t pid_ = -1;
  std::string name_;
};

class Observer {
 public:
  explicit Observer(const std::string& display);
  ~Observer();
  Observer(const Observer&) = delete;
  Observer& operator=(const Observer&) = delete;
  bool ok() const { return display_ != nullptr; }

  // The window's RGB pixels, top row first; empty when it cannot be read.
  std::vector<std::uint8_t> rgb(unsigned long window, int w, int h);
  void resize(unsigned long window, int w, int h);
  // What a window manager sends when the user clicks the close button.
  void ask_to_close(unsigned long window);

 private:
  void* display_;
};

}  // namespace dco::compositor
