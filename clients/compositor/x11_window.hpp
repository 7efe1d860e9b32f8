#pragma once

// An X11 window for the compositor's on-screen mode: the X connection, a window with the visual
// EGL asked for, and the events a viewer needs (close, resize).

#include <memory>
#include <string>

namespace dco::compositor {

class X11Window {
 public:
  // Opens the X display (empty: $DISPLAY). Throws Error naming the display when there is none.
  explicit X11Window(const std::string& display_name);
  ~X11Window();
  X11Window(const X11Window&) = delete;
  X11Window& operator=(const X11Window&) = delete;

  // The Xlib Display*, for eglGetPlatformDisplay.
  void* native_display() const;
  // Creates and maps the window with the visual EGL's configuration names.
  void create(unsigned long visual_id, int width, int height, const std::string& title);
  // The Window id's storage, for eglCreatePlatformWindowSurface.
  void* native_window();
  unsigned long window_id() const;

  // Handles pending events; false once the user asked to close the window.
  bool poll();
  int width() const { return width_; }
  int height() const { return height_; }

 private:
  struct Native;
  std::unique_ptr<Native> native_;
  int width_ = 0, height_ = 0;
  bool closed_ = false;
};

}  // namespace dco::compositor
