// The compositor's window on a real X server (Xvfb): what reaches the window is the composite,
// pixel for pixel, letterboxed when the window has another aspect; closing the window ends it;
// a display that is not there is one clear error.

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "dco/compositor/renderer.hpp"
#include "dco/ipc/ring_writer.hpp"
#include "exact_scene.hpp"
#include "support/commands.hpp"
#include "support/temp_dir.hpp"
#include "x_server.hpp"

namespace dco::compositor {
namespace {

// One X server for the whole binary: a renderer's X connection lives as long as the process
// (as its EGL display does), so a server must not go and another come back under its name.
const std::string& x_display() {
  static Xvfb server;
  return server.name();
}

// The composite as RGB, top row first.
std::vector<std::uint8_t> rgb_of(const std::vector<std::uint8_t>& rgba) {
  std::vector<std::uint8_t> out(rgba.size() / 4 * 3);
  for (std::size_t i = 0; i < rgba.size() / 4; ++i) std::memcpy(&out[3 * i], &rgba[4 * i], 3);
  return out;
}

// Presents until the observer sees what it expects (the X server takes the swap asynchronously)
// or two seconds pass; returns what it saw last.
std::vector<std::uint8_t> shown(Renderer& r, Observer& o, int w, int h,
                                const std::vector<std::uint8_t>& expected) {
  std::vector<std::uint8_t> got;
  for (const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(2);
       std::chrono::steady_clock::now() < until;) {
    EXPECT_TRUE(r.present());
    got = o.rgb(r.window_id(), w, h);
    if (got == expected) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return got;
}

long differing(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b) {
  if (a.size() != b.size()) return -1;
  long n = 0;
  for (std::size_t i = 0; i < a.size(); ++i) n += a[i] != b[i];
  return n;
}

TEST(CompositorWindow, ShowsTheCompositeLetterboxedAndClosesWhenAsked) {
  ASSERT_FALSE(x_display().empty()) << "Xvfb did not start (scripts/setup installs it)";
  Observer observer(x_display());
  ASSERT_TRUE(observer.ok());

  const ExactScene e = make_scene();
  WindowOptions wo;
  wo.display = x_display();
  wo.width = kW;
  wo.height = kH;
  Renderer r(wo);
  ASSERT_TRUE(r.windowed());
  ASSERT_NE(r.window_id(), 0u);
  const RenderTimes t = r.render(frame_of(e), e.scene, {});
  EXPECT_GT(t.gpu_ms, 0.0);
  const std::vector<std::uint8_t> composite = rgb_of(r.read_rgba());
  // The occlusion really is in the picture: cube pixels differ from the camera's grey.
  long coloured = 0;
  for (std::size_t i = 0; i < composite.size(); i += 3)
    coloured += composite[i] != composite[i + 1] || composite[i + 1] != composite[i + 2];
  EXPECT_GT(coloured, 20000);

  // Same size: the window holds the composite exactly.
  EXPECT_EQ(differing(shown(r, observer, kW, kH, composite), composite), 0);

  // Twice as wide: the frame at its own size in the middle, black bars either side.
  observer.resize(r.window_id(), 2 * kW, kH);
  std::vector<std::uint8_t> letterboxed(static_cast<std::size_t>(2 * kW) * kH * 3, 0);
  for (int y = 0; y < kH; ++y)
    std::memcpy(&letterboxed[(static_cast<std::size_t>(y) * 2 * kW + kW / 2) * 3],
                &composite[static_cast<std::size_t>(y) * kW * 3], static_cast<std::size_t>(kW) * 3);
  EXPECT_EQ(differing(shown(r, observer, 2 * kW, kH, letterboxed), letterboxed), 0);

  // A new frame of another size shows at once.
  RealFrame half = frame_of(e);
  half.camera.width = kW / 2;
  half.camera.height = kH / 2;
  half.camera.cx /= 2;
  half.camera.cy /= 2;
  r.render(half, e.scene, {});
  EXPECT_TRUE(r.present());

  observer.ask_to_close(r.window_id());
  bool open = true;
  for (int i = 0; i < 100 && open; ++i) {
    open = r.present();
    if (open) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_FALSE(open) << "the window ignored WM_DELETE_WINDOW";
  EXPECT_FALSE(r.present());
}

TEST(CompositorWindow, NoDisplayIsOneClearError) {
  std::string message;
  try {
    WindowOptions wo;
    wo.display = ":1234";  // Xvfb's -displayfd never hands out a number this high here
    Renderer r(wo);
  } catch (const Error& ex) {
    message = ex.what();
  }
  EXPECT_NE(message.find("cannot open the X display ':1234'"), std::string::npos) << message;
  message.clear();
  try {
    WindowOptions wo;
    wo.width = 0;
    Renderer r(wo);
  } catch (const Error& ex) {
    message = ex.what();
  }
  EXPECT_NE(message.find("window size 0x480"), std::string::npos) << message;
  // The command line says the same in one line.
  const auto out =
      dco::testing::run_command(std::string(DCO_COMPOSITOR_BIN) + " --display :1234 --wait 0 2>&1");
  EXPECT_NE(out.status, 0);
  EXPECT_NE(out.output.find("dco-compositor:"), std::string::npos) << out.output;
}

TEST(CompositorWindow, TheCommandShowsTheDaemonsFramesInAWindow) {
  ASSERT_FALSE(x_display().empty()) << "Xvfb did not start (scripts/setup installs it)";
  dco::testing::TempDir dir;
  const ExactScene e = make_scene();
  const std::string ring = (dir.path() / "depth.shm").string();
  ipc::RingOptions o;
  o.width = kW;
  o.height = kH;
  ipc::FrameMeta meta = ring_meta();
  std::atomic<bool> stop{false};
  ipc::RingWriter w(ring, o);
  std::thread writer([&] {
    for (int i = 0; i < 300 && !stop; ++i) {
      write_scene(w, e, meta, static_cast<std::uint64_t>(i), kW, kH);
      std::this_thread::sleep_for(std::chrono::milliseconds(33));
    }
  });
  const auto r =
      dco::testing::run_command(std::string(DCO_COMPOSITOR_BIN) + " --ring " + ring +
                                " --display " + x_display() + " --frames 5 --wait 5 2>&1");
  stop = true;
  writer.join();
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("in a window"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("frame 4 seq"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("GPU "), std::string::npos) << r.output;
}

}  // namespace
}  // namespace dco::compositor
