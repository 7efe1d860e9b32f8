#include "x_server.hpp"

#include <X11/Xlib.h>
#include <X11/Xutil.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>

namespace dco::compositor {
namespace {

int shift_of(unsigned long mask) {
  int s = 0;
  while (mask && !(mask & 1)) {
    mask >>= 1;
    ++s;
  }
  return s;
}

}  // namespace

Xvfb::Xvfb() {
  int fds[2];
  if (pipe(fds) != 0) return;
  pid_ = fork();
  if (pid_ == 0) {
    close(fds[0]);
    const std::string fd = std::to_string(fds[1]);
    execlp("Xvfb", "Xvfb", "-displayfd", fd.c_str(), "-screen", "0", "1600x1000x24", "-nolisten",
           "tcp", "-noreset", static_cast<char*>(nullptr));
    _exit(127);
  }
  close(fds[1]);
  std::string number;
  pollfd p{fds[0], POLLIN, 0};
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < until && poll(&p, 1, 200) >= 0) {
    if (!(p.revents & (POLLIN | POLLHUP))) continue;
    char c = 0;
    if (read(fds[0], &c, 1) != 1 || c == '\n') break;
    number += c;
  }
  close(fds[0]);
  if (!number.empty()) name_ = ":" + number;
}

Xvfb::~Xvfb() {
  if (pid_ > 0) {
    kill(pid_, SIGTERM);
    waitpid(pid_, nullptr, 0);
  }
}

Observer::Observer(const std::string& display) : display_(XOpenDisplay(display.c_str())) {}

Observer::~Observer() {
  if (display_) XCloseDisplay(static_cast<Display*>(display_));
}

std::vector<std::uint8_t> Observer::rgb(unsigned long window, int w, int h) {
  std::vector<std::uint8_t> out;
  XImage* image = XGetImage(static_cast<Display*>(display_), window, 0, 0, static_cast<unsigned>(w),
                            static_cast<unsigned>(h), AllPlanes, ZPixmap);
  if (!image) return out;
  const int rs = shift_of(image->red_mask), gs = shift_of(image->green_mask),
            bs = shift_of(image->blue_mask);
  out.resize(static_cast<std::size_t>(w) * h * 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const unsigned long p = XGetPixel(image, x, y);
      std::uint8_t* o = &out[(static_cast<std::size_t>(y) * w + x) * 3];
      o[0] = static_cast<std::uint8_t>((p & image->red_mask) >> rs);
      o[1] = static_cast<std::uint8_t>((p & image->green_mask) >> gs);
      o[2] = static_cast<std::uint8_t>((p & image->blue_mask) >> bs);
    }
  XDestroyImage(image);
  return out;
}

void Observer::resize(unsigned long window, int w, int h) {
  auto* d = static_cast<Display*>(display_);
  XResizeWindow(d, window, static_cast<unsigned>(w), static_cast<unsigned>(h));
  XSync(d, False);
}

void Observer::ask_to_close(unsigned long window) {
  auto* d = static_cast<Display*>(display_);
  XEvent e{};
  e.xclient.type = ClientMessage;
  e.xclient.window = window;
  e.xclient.message_type = XInternAtom(d, "WM_PROTOCOLS", False);
  e.xclient.format = 32;
  e.xclient.data.l[0] = static_cast<long>(XInternAtom(d, "WM_DELETE_WINDOW", False));
  e.xclient.data.l[1] = CurrentTime;
  XSendEvent(d, window, False, NoEventMask, &e);
  XSync(d, False);
}

}  // namespace dco::compositor
