#include "x11_window.hpp"

#include <X11/Xlib.h>
#include <X11/Xutil.h>

#include <map>
#include <mutex>

#include "dco/compositor/scene.hpp"

namespace dco::compositor {
namespace {

// One X connection per display name for the whole process: the EGL display made on it lives
// until exit, so the connection must too. Xlib is told first that several threads may use it.
Display* shared_connection(const std::string& name) {
  static std::mutex mutex;
  static std::map<std::string, Display*> open;
  std::lock_guard lock(mutex);
  if (const auto it = open.find(name); it != open.end()) return it->second;
  static const bool threads = XInitThreads() != 0;
  (void)threads;
  Display* d = XOpenDisplay(name.empty() ? nullptr : name.c_str());
  if (d) open.emplace(name, d);
  return d;
}

}  // namespace

struct X11Window::Native {
  Display* display = nullptr;
  Window window = 0;
  Colormap colormap = 0;
  Atom delete_window = 0;
};

X11Window::X11Window(const std::string& display_name) : native_(std::make_unique<Native>()) {
  native_->display = shared_connection(display_name);
  if (!native_->display) {
    const std::string name = display_name.empty() ? "$DISPLAY" : "'" + display_name + "'";
    throw Error("compositor: cannot open the X display " + name +
                " (no display there; without --window the compositor runs headless)");
  }
}

X11Window::~X11Window() {
  Native& n = *native_;
  if (n.window) XDestroyWindow(n.display, n.window);
  if (n.colormap) XFreeColormap(n.display, n.colormap);
  XFlush(n.display);
}

void* X11Window::native_display() const {
  return native_->display;
}
void* X11Window::native_window() {
  return &native_->window;
}
unsigned long X11Window::window_id() const {
  return native_->window;
}

void X11Window::create(unsigned long visual_id, int width, int height, const std::string& title) {
  Native& n = *native_;
  XVisualInfo wanted{};
  wanted.visualid = visual_id;
  int count = 0;
  XVisualInfo* info = XGetVisualInfo(n.display, VisualIDMask, &wanted, &count);
  if (!info || count < 1) throw Error("compositor: the X server lacks the visual EGL chose");
  const Window root = DefaultRootWindow(n.display);
  n.colormap = XCreateColormap(n.display, root, info->visual, AllocNone);
  XSetWindowAttributes attributes{};
  attributes.colormap = n.colormap;
  attributes.border_pixel = 0;
  attributes.background_pixel = 0;
  attributes.event_mask = StructureNotifyMask | ExposureMask;
  n.window = XCreateWindow(n.display, root, 0, 0, static_cast<unsigned>(width),
                           static_cast<unsigned>(height), 0, info->depth, InputOutput, info->visual,
                           CWColormap | CWBorderPixel | CWBackPixel | CWEventMask, &attributes);
  XFree(info);
  XStoreName(n.display, n.window, title.c_str());
  n.delete_window = XInternAtom(n.display, "WM_DELETE_WINDOW", False);
  XSetWMProtocols(n.display, n.window, &n.delete_window, 1);
  XMapWindow(n.display, n.window);
  XSync(n.display, False);
  width_ = width;
  height_ = height;
}

bool X11Window::poll() {
  Native& n = *native_;
  while (XPending(n.display) > 0) {
    XEvent event;
    XNextEvent(n.display, &event);
    if (event.type == ConfigureNotify) {
      width_ = event.xconfigure.width;
      height_ = event.xconfigure.height;
    } else if (event.type == ClientMessage &&
               static_cast<Atom>(event.xclient.data.l[0]) == n.delete_window) {
      closed_ = true;
    } else if (event.type == DestroyNotify && event.xdestroywindow.window == n.window) {
      n.window = 0;  // gone already: not ours to destroy again
      closed_ = true;
    }
  }
  return !closed_;
}

}  // namespace dco::compositor
