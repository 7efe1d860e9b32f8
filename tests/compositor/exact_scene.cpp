#include "exact_scene.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace dco::compositor {
namespace {

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

}  // namespace

bool in_hand(int u, int v) {
  const double du = u - 250, dv = v - 240;
  if (du * du + dv * dv < 60.0 * 60.0) return true;
  for (int f = 0; f < 4; ++f) {
    const int x0 = 200 + 28 * f;
    if (u >= x0 && u < x0 + 14 && v >= 120 && v < 240) return true;
  }
  return false;
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

ipc::FrameMeta ring_meta() {
  ipc::FrameMeta meta;
  meta.fx = kCamera.fx;
  meta.fy = kCamera.fy;
  meta.cx = kCamera.cx;
  meta.cy = kCamera.cy;
  meta.baseline_m = 0.12;
  return meta;
}

void write_scene(ipc::RingWriter& ring, const ExactScene& e, ipc::FrameMeta& meta,
                 std::uint64_t seq, int width, int height) {
  meta.frame_seq = seq;
  ring.write(ImageView<const float>(e.depth.data(), width, height, 1, kW),
             ImageView<const std::uint8_t>(e.image.data(), width, height, 1, kW), meta);
}

}  // namespace dco::compositor
