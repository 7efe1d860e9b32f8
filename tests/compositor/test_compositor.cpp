// The compositor on exact scenes: real depth of a hand with fingers in front of a slanted wall,
// a virtual cube behind the hand and a sphere half sunk into the wall. Its occlusion mask is
// compared with one ray-cast on the CPU at every pixel centre.

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <thread>
#include <vector>

#include "dco/compositor/renderer.hpp"
#include "dco/ipc/ring_writer.hpp"
#include "support/commands.hpp"
#include "support/temp_dir.hpp"

namespace dco::compositor {
namespace {

constexpr int kW = 640, kH = 400;
const Camera kCamera{kW, kH, 450.0, 450.0, 319.5, 199.5};

struct ExactScene {
  std::vector<float> depth;
  std::vector<std::uint8_t> image;
  Scene scene;
  std::vector<std::uint8_t> mask;  // 1 where a virtual object is visible
};

bool in_hand(int u, int v) {
  const double du = u - 250, dv = v - 240;
  if (du * du + dv * dv < 60.0 * 60.0) return true;
  for (int f = 0; f < 4; ++f) {
    const int x0 = 200 + 28 * f;
    if (u >= x0 && u < x0 + 14 && v >= 120 && v < 240) return true;
  }
  return false;
}

double hit_cube(const Cube& c, const double d[3]) {
  double t0 = 0, t1 = 1e30;
  for (int k = 0; k < 3; ++k) {
    const double lo = c.center[k] - c.size / 2.0, hi = c.center[k] + c.size / 2.0;
    const double a = lo / d[k], b = hi / d[k];
    t0 = std::max(t0, std::min(a, b));
    t1 = std::min(t1, std::max(a, b));
  }
  return t0 <= t1 ? t0 : 1e30;
}

double hit_sphere(const Sphere& s, const double d[3]) {
  const double a = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
  const double b = -2 * (d[0] * s.center[0] + d[1] * s.center[1] + d[2] * s.center[2]);
  const double c = s.center[0] * s.center[0] + s.center[1] * s.center[1] +
                   s.center[2] * s.center[2] - double(s.radius) * s.radius;
  const double disc = b * b - 4 * a * c;
  return disc < 0 ? 1e30 : (-b - std::sqrt(disc)) / (2 * a);
}

ExactScene make_scene() {
  ExactScene e;
  e.depth.resize(kW * kH);
  e.image.resize(kW * kH);
  e.mask.resize(kW * kH);
  e.scene.cubes.push_back(parse_cube("0.05,0.02,1.2,0.5"));
  e.scene.spheres.push_back(parse_sphere("-0.35,0.05,2.0,0.25"));
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u) {
      const int i = v * kW + u;
      const bool hand = in_hand(u, v);
      e.depth[i] = hand ? 0.7f : static_cast<float>(2.0 + 0.0006 * (u - 320));
      e.image[i] = static_cast<std::uint8_t>(hand ? 200 : 40 + (u + v) % 64);
      const double d[3] = {(u - kCamera.cx) / kCamera.fx, (v - kCamera.cy) / kCamera.fy, 1.0};
      const double z = std::min(hit_cube(e.scene.cubes[0], d), hit_sphere(e.scene.spheres[0], d));
      e.mask[i] = z < e.depth[i] ? 1 : 0;
    }
  return e;
}

bool boundary(const std::vector<std::uint8_t>& m, int u, int v) {
  const std::uint8_t c = m[v * kW + u];
  for (const auto& [du, dv] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
    const int x = u + du, y = v + dv;
    if (x >= 0 && x < kW && y >= 0 && y < kH && m[y * kW + x] != c) return true;
  }
  return false;
}

struct MaskScore {
  double iou = 0;
  double boundary_within_1px = 0;  // share of exact boundary pixels with a rendered one ≤ 1 px
  long exact_pixels = 0;
};

MaskScore score(const std::vector<std::uint8_t>& exact, const std::vector<std::uint8_t>& got) {
  MaskScore s;
  long inter = 0, uni = 0, edges = 0, near = 0;
  for (int i = 0; i < kW * kH; ++i) {
    inter += exact[i] && got[i];
    uni += exact[i] || got[i];
    s.exact_pixels += exact[i];
  }
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u) {
      if (!exact[v * kW + u] || !boundary(exact, u, v)) continue;
      ++edges;
      bool found = false;
      for (int dv = -1; dv <= 1 && !found; ++dv)
        for (int du = -1; du <= 1 && !found; ++du) {
          const int x = u + du, y = v + dv;
          found = x >= 0 && x < kW && y >= 0 && y < kH && got[y * kW + x] && boundary(got, x, y);
        }
      near += found;
    }
  s.iou = uni ? double(inter) / double(uni) : 1.0;
  s.boundary_within_1px = edges ? double(near) / double(edges) : 1.0;
  return s;
}

RealFrame frame_of(const ExactScene& e) {
  RealFrame f;
  f.camera = kCamera;
  f.depth = e.depth.data();
  f.depth_stride = kW * sizeof(float);
  f.image = e.image.data();
  f.image_stride = kW;
  return f;
}

std::vector<std::uint8_t> alpha_of(const std::vector<std::uint8_t>& rgba, int threshold) {
  std::vector<std::uint8_t> m(rgba.size() / 4);
  for (std::size_t i = 0; i < m.size(); ++i) m[i] = rgba[4 * i + 3] >= threshold ? 1 : 0;
  return m;
}

TEST(Compositor, HardOcclusionMatchesTheExactMask) {
  const ExactScene e = make_scene();
  Renderer r;
  const double ms = r.render(frame_of(e), e.scene, {});
  EXPECT_GT(ms, 0.0);
  const auto& rgba = r.read_rgba();
  const MaskScore s = score(e.mask, alpha_of(rgba, 128));
  std::printf("hard occlusion: IoU %.5f, boundary within 1 px %.4f (%ld visible px)\n", s.iou,
              s.boundary_within_1px, s.exact_pixels);
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
  ipc::FrameMeta meta;
  meta.fx = kCamera.fx;
  meta.fy = kCamera.fy;
  meta.cx = kCamera.cx;
  meta.cy = kCamera.cy;
  meta.baseline_m = 0.12;
  std::atomic<bool> stop{false};
  std::thread writer([&] {
    // A daemon that publishes 30 fps, stops after a while and comes back with a smaller size.
    {
      ipc::RingWriter w(ring, o);
      for (int i = 0; i < 15 && !stop; ++i) {
        meta.frame_seq = static_cast<std::uint64_t>(i);
        w.write(ImageView<const float>(e.depth.data(), kW, kH, 1, kW),
                ImageView<const std::uint8_t>(e.image.data(), kW, kH, 1, kW), meta);
        std::this_thread::sleep_for(std::chrono::milliseconds(33));
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    ipc::RingOptions small = o;
    small.width = kW / 2;
    small.height = kH / 2;
    ipc::RingWriter w(ring, small);
    for (int i = 0; i < 200 && !stop; ++i) {
      meta.frame_seq = 1000 + static_cast<std::uint64_t>(i);
      w.write(ImageView<const float>(e.depth.data(), kW / 2, kH / 2, 1, kW),
              ImageView<const std::uint8_t>(e.image.data(), kW / 2, kH / 2, 1, kW), meta);
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
  EXPECT_NE(r.output.find("render "), std::string::npos);
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
  // Scene files name the line at fault.
  std::ofstream(dir.path() / "scene.txt") << "# objects\ncube 0 0 1 0.2\ntorus 0 0 1 1\n";
  std::string message;
  try {
    load_scene((dir.path() / "scene.txt").string());
  } catch (const Error& ex) {
    message = ex.what();
  }
  EXPECT_NE(message.find("scene.txt:3: unknown object 'torus'"), std::string::npos) << message;
}

}  // namespace
}  // namespace dco::compositor
