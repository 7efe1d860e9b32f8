#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "dco/compositor/scene.hpp"

namespace dco::compositor {

// The rectified left camera the depth map is aligned to (pinhole, pixels).
struct Camera {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
};

// One frame of real depth (metres; 0, NaN or inf where unknown) and the camera image it belongs
// to (8-bit grey, or none).
struct RealFrame {
  Camera camera;
  const float* depth = nullptr;
  std::size_t depth_stride = 0;  // bytes
  const std::uint8_t* image = nullptr;
  std::size_t image_stride = 0;
};

struct RenderOptions {
  // 0: hard occlusion (the depth test against real depth). N > 0: soft occlusion, each virtual
  // pixel's coverage is the fraction of real depth behind it in a (2N+1)² window, so edges blend
  // over N pixels around the depth contours and nowhere else.
  int soft_radius_px = 0;
  // Depth range drawn. The far plane defaults to infinity: a virtual object however far is drawn
  // in front of unknown (+inf) or farther real depth; 1 - near/z keeps metres apart at 100 m.
  float near_m = kNearPlaneM, far_m = std::numeric_limits<float>::infinity();
};

// An on-screen window on an X display, for a desk setup or a headset driven as a display.
struct WindowOptions {
  std::string display;  // X display name; empty: $DISPLAY
  int width = 640, height = 480;
  std::string title = "dco-compositor";
};

// Where a headless renderer gets its EGL display: the surfaceless platform
// (EGL_MESA_platform_surfaceless: Mesa, llvmpipe included, and NVIDIA's recent drivers), or a
// GPU enumerated as an EGL device (EGL_EXT_platform_device: NVIDIA's drivers, including those
// without the surfaceless platform, and Mesa). Auto tries surfaceless, then each device in turn.
enum class HeadlessDisplay { kAuto, kSurfaceless, kDevice };

// "auto", "surfaceless" or "device" (dco-compositor --egl); throws Error for anything else.
HeadlessDisplay parse_headless_display(const std::string& name);

struct RenderTimes {
  double gpu_ms = -1;  // the GPU's own time (EXT_disjoint_timer_query); < 0 where the GL has none
  double wall_ms = 0;  // from the first upload to glFinish
  bool drawn = true;   // false: the frame was given up after its upload (see render())
};

// An EGL GLES 3 context and an offscreen framebuffer, rendering the camera image with real depth
// in the depth buffer and virtual objects depth-tested against it. Headless by default (see
// HeadlessDisplay); with WindowOptions the frames are also shown in an X11 window. Every GL call
// is checked; a failure throws Error naming the step. Each call makes the renderer's own context
// current, so several renderers may share a thread.
class Renderer {
 public:
  Renderer();
  explicit Renderer(HeadlessDisplay headless);
  explicit Renderer(const WindowOptions& window);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Renders one frame; the framebuffer follows the frame's size (a daemon restarted with another
  // resolution just reallocates). `keep`, when given, is asked once the frame's pixels are
  // uploaded (the GL has copied them then): false gives the frame up before anything is drawn,
  // and the framebuffer keeps the last frame drawn.
  RenderTimes render(const RealFrame& frame, const Scene& scene, const RenderOptions& options,
                     const std::function<bool()>& keep = {});

  // The last frame, top row first: RGBA8 where alpha is the virtual objects' coverage (0 where
  // the camera shows, 255 where a virtual object is fully visible).
  const std::vector<std::uint8_t>& read_rgba();

  bool windowed() const;
  // Windowed: handles the window's events and shows the last frame in it, scaled to fit with
  // its aspect kept. False once the window was closed (nothing is drawn then). Headless: false.
  bool present();
  // The X window's id (0 when headless), for tools that look at the window.
  unsigned long window_id() const;

  const char* gl_renderer() const;
  // The EGL display it renders on: "X11", "surfaceless" or "EGL device N of M".
  const std::string& egl_display() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Writes an 8-bit RGBA (4 channels), RGB (3) or grey (1) PNG, top row first. Throws Error.
void write_png(const std::string& path, const std::uint8_t* pixels, int width, int height,
               int channels);

}  // namespace dco::compositor
