// The compositor on exact scenes (exact_scene.hpp): its occlusion mask against the one ray-cast
// on the CPU, soft occlusion, following the daemon's ring, bad input.

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <thread>
#include <vector>

#include "dco/compositor/renderer.hpp"
#include "dco/ipc/ring_writer.hpp"
#include "exact_scene.hpp"
#include "support/commands.hpp"
#include "support/file_size_limit.hpp"
#include "support/temp_dir.hpp"

namespace dco::compositor {
namespace {

std::vector<std::uint8_t> alpha_of(const std::vector<std::uint8_t>& rgba, int threshold) {
  std::vector<std::uint8_t> m(rgba.size() / 4);
  for (std::size_t i = 0; i < m.size(); ++i) m[i] = rgba[4 * i + 3] >= threshold ? 1 : 0;
  return m;
}

TEST(Compositor, HardOcclusionMatchesTheExactMask) {
  const ExactScene e = make_scene();
  Renderer r;
  const RenderTimes t = r.render(frame_of(e), e.scene, {});
  EXPECT_GT(t.wall_ms, 0.0);
  // Mesa's llvmpipe has EXT_disjoint_timer_query: the GPU's own time is there, and within the
  // wall time around it.
  EXPECT_GT(t.gpu_ms, 0.0);
  EXPECT_LE(t.gpu_ms, t.wall_ms + 1.0);
  const auto& rgba = r.read_rgba();
  const MaskScore s = score(e.mask, alpha_of(rgba, 128));
  std::printf(
      "hard occlusion: IoU %.5f, boundary within 1 px %.4f (%ld visible px); GPU %.2f ms, "
      "upload to glFinish %.2f ms\n",
      s.iou, s.boundary_within_1px, s.exact_pixels, t.gpu_ms, t.wall_ms);
  EXPECT_GT(s.exact_pixels, 20000);
  EXPECT_GE(s.iou, 0.99);
  EXPECT_GE(s.boundary_within_1px, 0.99);
  // Hard means hard: every pixel is camera or object, nothing in between.
  for (std::size_t i = 3; i < rgba.size(); i += 4) ASSERT_TRUE(rgba[i] == 0 || rgba[i] == 255);
  // Where the camera shows, it shows the camera image unchanged.
  const int finger = 125 * kW + 205, wall = 20 * kW + 20;
  EXPECT_EQ(e.mask[finger], 0);
  EXPECT_EQ(rgba[4 * finger], 200);
  EXPECT_EQ(rgba[4 * wall], e.image[wall]);
}

// Either headless EGL display draws the same composite: the surfaceless platform and the EGL
// device platform. Mesa (here, CI) has both, enumerating its software device; so do NVIDIA's
// recent drivers, and where a driver lacks the surfaceless platform auto takes a device.
TEST(Compositor, EachHeadlessDisplayDrawsTheExactMask) {
  const ExactScene e = make_scene();
  Renderer automatic;
  const bool on_device = automatic.egl_display().rfind("EGL device ", 0) == 0;
  EXPECT_TRUE(on_device || automatic.egl_display() == "surfaceless") << automatic.egl_display();
  ASSERT_TRUE(automatic.render(frame_of(e), e.scene, {}).drawn);
  const std::vector<std::uint8_t> expected = automatic.read_rgba();
  for (HeadlessDisplay which : {HeadlessDisplay::kSurfaceless, HeadlessDisplay::kDevice}) {
    const bool device = which == HeadlessDisplay::kDevice;
    std::unique_ptr<Renderer> r;
    try {
      r = std::make_unique<Renderer>(which);
    } catch (const Error& error) {
      // Only where auto had to take a device may the surfaceless platform be missing.
      EXPECT_TRUE(on_device && !device) << error.what();
      std::printf("%s\n", error.what());
      continue;
    }
    std::printf("%s: %s\n", r->egl_display().c_str(), r->gl_renderer());
    EXPECT_EQ(r->egl_display().rfind(device ? "EGL device " : "surfaceless", 0), 0u);
    ASSERT_TRUE(r->render(frame_of(e), e.scene, {}).drawn);
    EXPECT_GE(score(e.mask, alpha_of(r->read_rgba(), 128)).iou, 0.99);
    EXPECT_EQ(r->read_rgba(), expected);
  }
  EXPECT_EQ(parse_headless_display("device"), HeadlessDisplay::kDevice);
  EXPECT_EQ(parse_headless_display("surfaceless"), HeadlessDisplay::kSurfaceless);
  EXPECT_EQ(parse_headless_display("auto"), HeadlessDisplay::kAuto);
  EXPECT_THROW(parse_headless_display("wayland"), Error);
}

// A frame given up after its upload (its slot was rewritten meanwhile) draws nothing: the
// framebuffer keeps the last frame drawn.
TEST(Compositor, AFrameGivenUpAfterItsUploadLeavesTheLastOne) {
  const ExactScene e = make_scene();
  Renderer r;
  ASSERT_TRUE(r.render(frame_of(e), e.scene, {}).drawn);
  const std::vector<std::uint8_t> shown = r.read_rgba();
  Scene other = e.scene;
  other.cubes.clear();
  other.spheres.clear();
  int asked = 0;
  const RenderTimes t = r.render(frame_of(e), other, {}, [&] {
    ++asked;
    return false;
  });
  EXPECT_FALSE(t.drawn);
  EXPECT_EQ(asked, 1);
  EXPECT_EQ(r.read_rgba(), shown);
  // So does one of another size (the first of a new ring session), given up the same way.
  RealFrame smaller = frame_of(e);
  smaller.camera.width = kW / 2;
  smaller.camera.height = kH / 2;
  EXPECT_FALSE(r.render(smaller, e.scene, {}, [] { return false; }).drawn);
  EXPECT_EQ(r.read_rgba(), shown);
  ASSERT_TRUE(r.render(smaller, e.scene, {}).drawn);
  EXPECT_EQ(r.read_rgba().size(), static_cast<std::size_t>(kW / 2) * (kH / 2) * 4);
}

// No far plane: a virtual object 150 or 300 m away is drawn in front of unknown real depth, and
// behind real depth nearer than it.
TEST(Compositor, FarObjectsAreDrawnInFrontOfUnknownDepth) {
  std::vector<float> depth(static_cast<std::size_t>(kW) * kH,
                           std::numeric_limits<float>::infinity());
  for (int v = 0; v < kH; ++v)
    for (int u = kW / 2; u < kW; ++u) depth[static_cast<std::size_t>(v) * kW + u] = 200.0f;
  RealFrame frame;
  frame.camera = kCamera;
  frame.depth = depth.data();
  frame.depth_stride = kW * sizeof(float);
  Scene scene;
  scene.cubes.push_back({{-20.0f, 0.0f, 150.0f}, 10.0f});   // left: unknown depth behind it
  scene.spheres.push_back({{40.0f, 0.0f, 300.0f}, 20.0f});  // right: a wall at 200 m in front
  Renderer r;
  ASSERT_TRUE(r.render(frame, scene, {}).drawn);
  const std::vector<std::uint8_t> alpha = alpha_of(r.read_rgba(), 128);
  const auto at = [&](double x, double z) {
    const int u = static_cast<int>(std::lround(kCamera.cx + kCamera.fx * x / z));
    return alpha[static_cast<std::size_t>(kH / 2) * kW + u];
  };
  EXPECT_EQ(at(-20.0, 145.0), 1);
  EXPECT_EQ(at(40.0, 280.0), 0);
  // A nearer sphere in the same place is in front of the wall.
  scene.spheres[0].center[2] = 190.0f;
  scene.spheres[0].center[0] = 25.0f;
  ASSERT_TRUE(r.render(frame, scene, {}).drawn);
  const std::vector<std::uint8_t> again = alpha_of(r.read_rgba(), 128);
  const int u = static_cast<int>(std::lround(kCamera.cx + kCamera.fx * 25.0 / 170.0));
  EXPECT_EQ(again[static_cast<std::size_t>(kH / 2) * kW + u], 1);
  RenderOptions bad;
  bad.far_m = bad.near_m;
  EXPECT_THROW(r.render(frame, scene, bad), Error);
}

// However far: a cube 900 km away over unknown depth, and one 9 km away in front of a real
// surface 1 % farther, where 1 - n / z in a float no longer tells the two apart.
TEST(Compositor, ObjectsHundredsOfKilometresAwayKeepTheirDepthOrder) {
  std::vector<float> depth(static_cast<std::size_t>(kW) * kH,
                           std::numeric_limits<float>::infinity());
  for (int v = 0; v < kH; ++v)
    for (int u = kW / 2; u < kW; ++u) depth[static_cast<std::size_t>(v) * kW + u] = 9.1e3f;
  RealFrame frame;
  frame.camera = kCamera;
  frame.depth = depth.data();
  frame.depth_stride = kW * sizeof(float);
  Scene scene;
  scene.cubes.push_back({{-1.2e5f, 0.0f, 9.0e5f}, 6.0e4f});  // left, over unknown depth
  scene.cubes.push_back({{1.2e3f, 0.0f, 9.0e3f}, 6.0e1f});   // right, 1 % before the wall
  Renderer r;
  for (const int soft : {0, 2}) {
    RenderOptions options;
    options.soft_radius_px = soft;
    ASSERT_TRUE(r.render(frame, scene, options).drawn);
    const std::vector<std::uint8_t> alpha = alpha_of(r.read_rgba(), 128);
    const auto at = [&](double x, double z) {
      const int u = static_cast<int>(std::lround(kCamera.cx + kCamera.fx * x / z));
      return alpha[static_cast<std::size_t>(kH / 2) * kW + u];
    };
    EXPECT_EQ(at(-1.2e5, 8.7e5), 1) << "soft " << soft;
    EXPECT_EQ(at(1.2e3, 8.97e3), 1) << "soft " << soft;
  }
  // Behind the wall the near cube is hidden.
  scene.cubes[1].center[2] = 9.3e3f;
  ASSERT_TRUE(r.render(frame, scene, {}).drawn);
  const std::vector<std::uint8_t> alpha = alpha_of(r.read_rgba(), 128);
  const int u = static_cast<int>(std::lround(kCamera.cx + kCamera.fx * 1.2e3 / 9.27e3));
  EXPECT_EQ(alpha[static_cast<std::size_t>(kH / 2) * kW + u], 0);
}

// A PNG that cannot be written whole (a full disk: here a file size limit) leaves the last good
// one in place and no partial file.
TEST(Compositor, AFailedPngWriteLeavesTheLastGoodOne) {
  dco::testing::TempDir dir;
  const std::string path = (dir / "frame.png").string();
  const std::vector<std::uint8_t> good(64 * 48, 100);
  write_png(path, good.data(), 64, 48, 1);
  const std::string before = dco::testing::read_file(path);
  std::vector<std::uint8_t> noise(640 * 400 * 3);
  std::uint32_t x = 12345;
  for (std::uint8_t& v : noise)
    v = static_cast<std::uint8_t>((x = x * 1664525u + 1013904223u) >> 24);
  EXPECT_EQ(dco::testing::status_of_write_past_file_limit(
                4096, [&] { write_png(path, noise.data(), 640, 400, 3); }),
            dco::testing::kWriteThrew)
      << "the write should have failed";
  EXPECT_EQ(dco::testing::read_file(path), before);
  for (const auto& e : std::filesystem::directory_iterator(dir.path()))
    EXPECT_EQ(e.path().filename(), "frame.png") << "left behind";
}

// The temporary file has a name of its own: a link planted at a guessable one (in a shared
// directory) is never written through.
TEST(Compositor, APngIsNeverWrittenThroughALinkPlantedBesideIt) {
  dco::testing::TempDir dir;
  const std::string path = (dir / "o.png").string();
  std::ofstream(dir / "victim") << "keep me";
  std::filesystem::create_symlink(dir / "victim", path + ".tmp");
  const std::vector<std::uint8_t> pixels(16 * 8, 7);
  write_png(path, pixels.data(), 16, 8, 1);
  EXPECT_EQ(dco::testing::read_file((dir / "victim").string()), "keep me");
  EXPECT_TRUE(std::filesystem::is_regular_file(std::filesystem::symlink_status(path)));
}

// Under a file size limit (LimitFSIZE=, ulimit -f) the tool reports the failed write and exits
// 1: no SIGXFSZ, no temporary file left, one line (libpng's own message inside the tool's).
TEST(Compositor, AFileSizeLimitIsOneErrorLine) {
  dco::testing::TempDir dir;
  const std::string ring = (dir.path() / "depth.shm").string();
  ipc::RingWriter w(ring, ipc::RingOptions{320, 240, 3});
  std::vector<float> depth(320 * 240, 2.0f);
  std::vector<std::uint8_t> image(320 * 240 * 3);
  std::uint32_t x = 1;
  for (std::uint8_t& v : image)
    v = static_cast<std::uint8_t>((x = x * 1664525u + 1013904223u) >> 24);
  w.write(ImageView<const float>(depth.data(), 320, 240, 1, 320),
          ImageView<const std::uint8_t>(image.data(), 320, 240, 3, 320 * 3),
          {1, 0, 300.0, 300.0, 160.0, 120.0, 0.1});
  const auto r = dco::testing::run_command("ulimit -f 8 && " + std::string(DCO_COMPOSITOR_BIN) +
                                           " --wait 1 --frames 1 --ring " + ring + " --out " +
                                           (dir.path() / "f.png").string() + " 2>&1");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("write failed"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("libpng error"), std::string::npos) << r.output;
  for (const auto& e : std::filesystem::directory_iterator(dir.path()))
    EXPECT_EQ(e.path().filename(), "depth.shm") << "left behind";
}

// Two renderers on one thread (one per eye, say): each draws and reads in its own context, and
// one going away leaves the other working.
TEST(Compositor, TwoRenderersOnOneThreadKeepTheirOwnFrames) {
  const ExactScene e = make_scene();
  Scene other = e.scene;
  other.cubes[0].center[1] -= 0.15f;
  auto a = std::make_unique<Renderer>();
  ASSERT_TRUE(a->render(frame_of(e), e.scene, {}).drawn);
  const std::vector<std::uint8_t> first = a->read_rgba();
  Renderer b;
  ASSERT_TRUE(b.render(frame_of(e), other, {}).drawn);
  const std::vector<std::uint8_t> second = b.read_rgba();
  EXPECT_NE(first, second);
  EXPECT_EQ(a->read_rgba(), first);
  ASSERT_TRUE(a->render(frame_of(e), e.scene, {}).drawn);
  EXPECT_EQ(b.read_rgba(), second);
  a.reset();
  EXPECT_EQ(b.read_rgba(), second);
  ASSERT_TRUE(b.render(frame_of(e), other, {}).drawn);
  EXPECT_EQ(b.read_rgba(), second);
}

// The objects' vertices are uploaded again only when a box changed: a renderer that drew one
// scene draws a moved, grown, added or removed object exactly as a new renderer does.
TEST(Compositor, ChangedObjectsAreDrawnAsANewRendererDrawsThem) {
  const ExactScene e = make_scene();
  Renderer r;
  ASSERT_TRUE(r.render(frame_of(e), e.scene, {}).drawn);
  const std::vector<std::uint8_t> first = r.read_rgba();
  Scene moved = e.scene;
  moved.cubes[0].center[0] += 0.1f;
  Scene grown = e.scene;
  grown.spheres[0].radius *= 1.5f;
  Scene added = e.scene;
  added.cubes.push_back(parse_cube("-0.2,-0.1,1.0,0.1"));
  Scene removed = e.scene;
  removed.spheres.clear();
  for (const Scene* changed :
       std::initializer_list<const Scene*>{&moved, &grown, &added, &removed, &e.scene}) {
    ASSERT_TRUE(r.render(frame_of(e), *changed, {}).drawn);
    Renderer fresh;
    ASSERT_TRUE(fresh.render(frame_of(e), *changed, {}).drawn);
    EXPECT_EQ(r.read_rgba(), fresh.read_rgba());
    if (changed != &e.scene) {
      EXPECT_NE(r.read_rgba(), first);
    }
  }
  EXPECT_EQ(r.read_rgba(), first);
}

TEST(Compositor, SoftOcclusionBlendsOnlyNearDepthContours) {
  const ExactScene e = make_scene();
  Renderer r;
  RenderOptions soft;
  soft.soft_radius_px = 2;
  r.render(frame_of(e), e.scene, soft);
  const std::vector<std::uint8_t> rgba = r.read_rgba();
  // Pixels away from every contour (real or virtual) are as in the hard mask; along the hand's
  // outline over the cube coverage takes values in between.
  std::vector<std::uint8_t> hand(kW * kH);
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u) hand[v * kW + u] = in_hand(u, v);
  long far_checked = 0, far_wrong = 0, blended_on_hand_edge = 0;
  for (int v = 4; v < kH - 4; ++v)
    for (int u = 4; u < kW - 4; ++u) {
      bool near_edge = false;
      for (int dv = -3; dv <= 3 && !near_edge; ++dv)
        for (int du = -3; du <= 3 && !near_edge; ++du)
          near_edge = boundary(e.mask, u + du, v + dv) || boundary(hand, u + du, v + dv);
      const std::uint8_t a = rgba[4 * (v * kW + u) + 3];
      if (!near_edge) {
        ++far_checked;
        far_wrong += a != (e.mask[v * kW + u] ? 255 : 0);
      } else if (boundary(hand, u, v) && a > 0 && a < 255) {
        ++blended_on_hand_edge;
      }
    }
  EXPECT_GT(far_checked, 200000);
  EXPECT_LE(far_wrong, far_checked / 1000);
  EXPECT_GT(blended_on_hand_edge, 100);
  // Thresholded at half coverage it is still the exact mask, within a pixel.
  const MaskScore s = score(e.mask, alpha_of(rgba, 128));
  EXPECT_GE(s.iou, 0.98);
}

TEST(Compositor, FollowsTheRingAndWritesPngs) {
  dco::testing::TempDir dir;
  const ExactScene e = make_scene();
  const std::string ring = (dir.path() / "depth.shm").string();
  ipc::RingOptions o;
  o.width = kW;
  o.height = kH;
  ipc::FrameMeta meta = ring_meta();
  std::atomic<bool> stop{false};
  std::thread writer([&] {
    // A daemon that publishes 30 fps, stops once the compositor has shown its frames (a loaded
    // machine may start the compositor late) and comes back with a smaller size.
    {
      ipc::RingWriter w(ring, o);
      const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
      int after_first = 0;
      for (int i = 0; after_first < 5 && !stop && std::chrono::steady_clock::now() < give_up; ++i) {
        write_scene(w, e, meta, static_cast<std::uint64_t>(i), kW, kH);
        std::this_thread::sleep_for(std::chrono::milliseconds(33));
        if (i >= 14 && std::filesystem::exists(dir.path() / "frame_000.png")) ++after_first;
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    ipc::RingOptions small = o;
    small.width = kW / 2;
    small.height = kH / 2;
    ipc::RingWriter w(ring, small);
    for (int i = 0; i < 200 && !stop; ++i) {
      write_scene(w, e, meta, 1000 + static_cast<std::uint64_t>(i), kW / 2, kH / 2);
      std::this_thread::sleep_for(std::chrono::milliseconds(33));
    }
  });
  const std::string out = (dir.path() / "frame_%03d.png").string();
  const std::string mask = (dir.path() / "mask_%03d.png").string();
  const auto r = dco::testing::run_command(
      std::string(DCO_COMPOSITOR_BIN) + " --ring " + ring + " --frames 20 --wait 5 --out " + out +
      " --mask " + mask + " --cube 0.05,0.02,1.2,0.5 --sphere -0.35,0.05,2.0,0.25 2>&1");
  stop = true;
  writer.join();
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("dcod stopped; waiting"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("dcod is back"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("GPU "), std::string::npos) << r.output;
  // The first frame is the full-size scene: its mask is the exact one.
  const cv::Mat first = cv::imread((dir.path() / "mask_000.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(first.cols, kW);
  ASSERT_EQ(first.rows, kH);
  std::vector<std::uint8_t> got(kW * kH);
  for (int i = 0; i < kW * kH; ++i) got[i] = first.data[i] >= 128;
  EXPECT_GE(score(e.mask, got).iou, 0.99);
  const cv::Mat colour = cv::imread((dir.path() / "frame_000.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(colour.channels(), 3);
  // The last one comes from the restarted daemon, at its new size.
  const cv::Mat last = cv::imread((dir.path() / "frame_019.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(last.cols, kW / 2);
  EXPECT_EQ(last.rows, kH / 2);
}

TEST(Compositor, BadInputIsOneClearLine) {
  dco::testing::TempDir dir;
  const std::string bin = DCO_COMPOSITOR_BIN;
  auto r = dco::testing::run_command(bin + " --wait 0 --ring " + (dir.path() / "x.shm").string() +
                                     " 2>&1");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("is dcod running?"), std::string::npos) << r.output;
  r = dco::testing::run_command(bin + " --cube 1,2 2>&1");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("a cube takes X Y Z SIZE"), std::string::npos) << r.output;
  r = dco::testing::run_command(bin + " --sphere 0,0,-1,1 2>&1");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("in front of the camera"), std::string::npos) << r.output;
  r = dco::testing::run_command(bin + " --out 'a%s.png' 2>&1");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("one %d"), std::string::npos) << r.output;
  EXPECT_NE(dco::testing::run_command(bin + " --bogus 1 2>&1").output.find("unknown option"),
            std::string::npos);
  r = dco::testing::run_command(bin + " --egl wayland 2>&1");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("--egl takes auto, surfaceless or device, not 'wayland'"),
            std::string::npos)
      << r.output;
  r = dco::testing::run_command(bin + " --frames \"$(printf '1\\n2')\" 2>&1");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("not '1?2'"), std::string::npos) << r.output;
  // A ring of another size than asked for.
  const std::string ring = (dir.path() / "depth.shm").string();
  ipc::RingOptions o;
  o.width = 64;
  o.height = 48;
  ipc::RingWriter w(ring, o);
  r = dco::testing::run_command(bin + " --wait 1 --width 640 --height 400 --ring " + ring +
                                " 2>&1");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("64"), std::string::npos) << r.output;
  // The owner the ring must have: the packaged dcod runs as its own user.
  const std::string own = std::to_string(getuid());
  r = dco::testing::run_command(bin + " --wait 1 --uid " + std::to_string(getuid() + 1) +
                                " --ring " + ring + " 2>&1");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("wrong owner"), std::string::npos) << r.output;
  r = dco::testing::run_command(bin + " --wait 1 --uid " + own +
                                " --width 640 --height 400 --ring " + ring + " 2>&1");
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(r.output.find("wrong owner"), std::string::npos) << r.output;
  EXPECT_EQ(dco::testing::run_command(bin + " --uid -1 2>&1").status, 2);
  r = dco::testing::run_command(bin + " --cube 0,0,1,0.3, 2>&1");  // a comma and no number
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("'' is not a number"), std::string::npos) << r.output;
  // Nothing is drawn nearer than 1 cm: an object that reaches there is refused, not half shown.
  r = dco::testing::run_command(bin + " --sphere 0,0,0.25,0.25 2>&1");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("reaches to Z = 0 m; objects are drawn beyond 0.01 m"), std::string::npos)
      << r.output;
  r = dco::testing::run_command(bin + " --out 'x%2000000000d.png' 2>&1");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("N up to 20"), std::string::npos) << r.output;
  // Ctrl-C while it waits for dcod to start ends it at once.
  const auto start = std::chrono::steady_clock::now();
  r = dco::testing::run_command("timeout --preserve-status -s INT 1 " + bin + " --wait 30 --ring " +
                                (dir.path() / "none.shm").string() + " 2>&1");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("stopped while waiting"), std::string::npos) << r.output;
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10));
  // Scene files: CRLF line ends are read, too many objects are not.
  EXPECT_EQ(parse_scene("cube 0 0 1 0.3\r\nsphere 0 0 2 0.2\r\n", "crlf.txt").size(), 2u);
  std::string many;
  for (std::size_t i = 0; i <= kMaxObjects; ++i) many += "cube 0 0 2 0.1\n";
  try {
    parse_scene(many, "many.txt");
    ADD_FAILURE() << "took more than kMaxObjects objects";
  } catch (const Error& ex) {
    EXPECT_NE(std::string(ex.what()).find("more than 4096 objects"), std::string::npos)
        << ex.what();
  }
  // Scene files name the line at fault.
  std::ofstream(dir.path() / "scene.txt") << "# objects\ncube 0 0 1 0.2\ntorus 0 0 1 1\n";
  std::string message;
  try {
    load_scene((dir.path() / "scene.txt").string());
  } catch (const Error& ex) {
    message = ex.what();
  }
  EXPECT_NE(message.find("scene.txt:3: unknown object 'torus'"), std::string::npos) << message;
  // A directory, or a file with no object, is no scene (the default one is not put in its place).
  std::ofstream(dir.path() / "empty.txt") << "# nothing yet\n";
  for (const auto& [name, expected] :
       {std::pair{std::string("."), std::string("not a readable file")},
        std::pair{std::string("empty.txt"), std::string("no cube or sphere in it")}}) {
    try {
      load_scene((dir.path() / name).string());
      ADD_FAILURE() << name << " was taken as a scene";
    } catch (const Error& ex) {
      EXPECT_NE(std::string(ex.what()).find(expected), std::string::npos) << ex.what();
    }
  }
  // Options: an unknown last one is unknown (not one "needing a value"), --scene once, --width
  // and --height together, an empty --out refused.
  r = dco::testing::run_command(bin + " --bogus 2>&1");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("unknown option --bogus"), std::string::npos) << r.output;
  r = dco::testing::run_command(bin + " --scene a.txt --scene b.txt 2>&1");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("--scene given twice"), std::string::npos) << r.output;
  r = dco::testing::run_command(bin + " --width 161 2>&1");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("--width and --height go together"), std::string::npos) << r.output;
  r = dco::testing::run_command(bin + " --out '' 2>&1");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("--out: an empty file name"), std::string::npos) << r.output;
  // Numbers: a NUL inside one ends nothing, a value too small for a float is that tiny value,
  // and a long bad token is quoted in part.
  try {
    parse_scene(std::string("cube 0 0 1\0junk 0.3\n", 20), "nul.txt");
    ADD_FAILURE() << "took a number with a NUL in it";
  } catch (const Error& ex) {
    EXPECT_NE(std::string(ex.what()).find("nul.txt:1:"), std::string::npos) << ex.what();
  }
  EXPECT_EQ(parse_scene("cube 1e-40 0 1 0.3\n", "tiny.txt").size(), 1u);
  try {
    parse_scene("cube " + std::string(100000, '7') + "x 0 1 0.3\n", "long.txt");
    ADD_FAILURE() << "took a bad number";
  } catch (const Error& ex) {
    EXPECT_LT(std::string(ex.what()).size(), 200u) << "the message quotes all of it";
  }
  // A file larger than any scene is refused before it is read.
  std::ofstream(dir.path() / "huge.txt") << std::string(kMaxSceneBytes + 1, '#');
  try {
    load_scene((dir.path() / "huge.txt").string());
    ADD_FAILURE() << "read a file larger than any scene";
  } catch (const Error& ex) {
    EXPECT_NE(std::string(ex.what()).find("larger than 1 MiB"), std::string::npos) << ex.what();
  }
  // An argument quoted in an error stays on one line.
  try {
    parse_cube("0,0\n,1,0.3");
    ADD_FAILURE() << "took a cube with a line break in a number";
  } catch (const Error& ex) {
    EXPECT_EQ(std::string(ex.what()), "--cube '0,0?,1,0.3': '0?' is not a number") << ex.what();
  }
}

}  // namespace
}  // namespace dco::compositor
