#include "scene_render.hpp"

#include <cmath>

namespace dco::testing {
namespace {

double hash01(std::int64_t x, std::int64_t y, std::uint32_t salt) {
  std::uint64_t h = static_cast<std::uint64_t>(x) * 0x9E3779B97F4A7C15ull ^
                    static_cast<std::uint64_t>(y) * 0xC2B2AE3D27D4EB4Full ^ salt;
  h ^= h >> 31;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 29;
  return static_cast<double>(h & 0xffffff) / double(0xffffff);
}

// Bilinear value noise: texture with features of about `cell` metres.
double texture(double x, double y, double cell, std::uint32_t salt) {
  const double fx = x / cell, fy = y / cell;
  const auto ix = static_cast<std::int64_t>(std::floor(fx));
  const auto iy = static_cast<std::int64_t>(std::floor(fy));
  const double ax = fx - std::floor(fx), ay = fy - std::floor(fy);
  const double a = hash01(ix, iy, salt), b = hash01(ix + 1, iy, salt);
  const double c = hash01(ix, iy + 1, salt), d = hash01(ix + 1, iy + 1, salt);
  return (a * (1 - ax) + b * ax) * (1 - ay) + (c * (1 - ax) + d * ax) * ay;
}

// θ from the distorted radius θ_d = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸), by Newton.
double undistort_theta(double theta_d, const std::array<double, 4>& k) {
  double t = theta_d;
  for (int i = 0; i < 20; ++i) {
    const double t2 = t * t;
    const double f = t * (1 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3])))) - theta_d;
    const double df = 1 + t2 * (3 * k[0] + t2 * (5 * k[1] + t2 * (7 * k[2] + t2 * 9 * k[3])));
    const double step = f / df;
    t -= step;
    if (std::abs(step) < 1e-12) break;
  }
  return t;
}

void render_view(const indemind::CameraParameter& cam, double cam_x, double scale, int width,
                 int height, double box_depth, double wall_depth, std::uint8_t* out,
                 std::ptrdiff_t stride) {
  const double fx = cam.k[0] * scale, fy = cam.k[4] * scale;
  const double cx = (cam.k[2] + 0.5) * scale - 0.5, cy = (cam.k[5] + 0.5) * scale - 0.5;
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const double mx = (u - cx) / fx, my = (v - cy) / fy;
      const double theta_d = std::hypot(mx, my);
      const double theta = undistort_theta(theta_d, cam.d);
      const double s = theta_d > 1e-12 ? std::sin(theta) / theta_d : 1.0;
      const double dx = mx * s, dy = my * s, dz = std::cos(theta);
      double value = 0;
      bool hit = false;
      if (dz > 1e-6) {
        const double t = box_depth / dz;
        const double x = cam_x + dx * t, y = dy * t;
        if (x > -0.25 && x < 0.12 && y > -0.15 && y < 0.2) {
          value = 40 + 180 * texture(x, y, 0.006, 7);
          hit = true;
        }
        if (!hit) {
          const double tw = wall_depth / dz;
          value = 30 + 200 * texture(cam_x + dx * tw, dy * tw, 0.02, 11);
        }
      }
      out[v * stride + u] = static_cast<std::uint8_t>(std::lround(value));
    }
  }
}

}  // namespace

std::vector<std::uint8_t> render_side_by_side(const indemind::ModuleCalibration& calibration,
                                              int width, int height, double box_depth_m,
                                              double wall_depth_m) {
  std::vector<std::uint8_t> frame(std::size_t(width) * 2 * height);
  const double scale = static_cast<double>(width) / calibration.left.width;
  // The right camera sits baseline metres along +x of the left one (P_right[3] = -f·B).
  const double baseline = -calibration.right.p[3] / calibration.right.p[0];
  render_view(calibration.left, 0.0, scale, width, height, box_depth_m, wall_depth_m, frame.data(),
              2 * width);
  render_view(calibration.right, baseline, scale, width, height, box_depth_m, wall_depth_m,
              frame.data() + width, 2 * width);
  return frame;
}

}  // namespace dco::testing
