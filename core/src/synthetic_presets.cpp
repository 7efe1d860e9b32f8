// Named synthetic scenes. Positions and sizes are metric; the focal length follows the width
// (700 px at 1280) so a preset frames the same scene at any resolution, and texture grain is set
// in pixels (kGrainPx at the object's depth) so stereo matchers see the same detail everywhere.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <string>

#include "dco/core/error.hpp"
#include "dco/core/synthetic_scene.hpp"

namespace dco::synthetic {
namespace {

constexpr double kFocalAt1280 = 700;
constexpr double kGrainPx = 4;
constexpr double kUp = std::numbers::pi / 2;  // capsule angle of a vertical finger

Object make(Shape shape, double w, double h, double x, double y, double z, std::uint32_t seed,
            std::uint8_t brightness, double focal) {
  Object o;
  o.shape = shape;
  o.width_m = w;
  o.height_m = h;
  o.x_m = x;
  o.y_m = y;
  o.z_m = z;
  o.texture_seed = seed;
  o.brightness = brightness;
  o.texture_scale_m = kGrainPx * z / focal;
  return o;
}

void moves(Object& o, double ax, double ay, double az, double period, double phase) {
  o.amp_x_m = ax;
  o.amp_y_m = ay;
  o.amp_z_m = az;
  o.period_s = period;
  o.phase_rad = phase;
}

SceneConfig base(int width, int height) {
  SceneConfig c;
  c.width = width;
  c.height = height;
  c.focal_px = kFocalAt1280 * width / 1280.0;
  return c;
}

// A wall at 2.8 m leaning back towards the top, a box at 1.2 m, and a hand at 0.45-0.56 m: a
// palm disc and four fingers from ~25 px down to ~6 px wide (at 1280), swaying sideways and
// bobbing up and down with a 4 s period.
SceneConfig hand(int width, int height) {
  SceneConfig c = base(width, height);
  const double f = c.focal_px;
  c.background_z_m = 2.8;
  c.background_slope_x = 0.003;
  c.background_slope_y = 0.01;
  c.background_seed = 7;

  Object box = make(Shape::kBox, 0.42, 0.3, -0.15, -0.02, 1.2, 11, 85, f);
  box.angle_rad = 0.15;
  c.objects.push_back(box);

  Object palm = make(Shape::kDisc, 0.085, 0.095, 0.0, 0.1, 0.54, 21, 165, f);
  moves(palm, 0.06, 0.015, 0, 4, 0);
  c.objects.push_back(palm);

  struct Finger {
    double diameter, length, x, y, z, tilt, bob, phase;
  };
  constexpr Finger kFingers[] = {
      {0.016, 0.065, -0.058, 0.07, 0.45, 0.7, 0.010, 0.0},     // thumb, ~25 px
      {0.012, 0.085, -0.024, -0.005, 0.48, 0.12, 0.015, 0.3},  // ~17 px
      {0.009, 0.090, 0.006, -0.01, 0.52, 0.0, 0.020, 0.6},     // ~12 px
      {0.005, 0.075, 0.034, 0.005, 0.56, -0.15, 0.015, 0.9},   // ~6 px
  };
  std::uint32_t seed = 31;
  for (const Finger& k : kFingers) {
    Object o = make(Shape::kCapsule, k.length, k.diameter, k.x, k.y, k.z, seed++, 165, f);
    o.angle_rad = kUp + k.tilt;
    moves(o, 0.06, k.bob, 0, 4, k.phase);
    c.objects.push_back(o);
  }
  return c;
}

// Four boxes between 0.8 and 2.5 m in front of a wall at 4 m, sliding sideways and in depth.
SceneConfig boxes(int width, int height) {
  SceneConfig c = base(width, height);
  const double f = c.focal_px;
  c.background_z_m = 4.0;
  c.background_slope_x = 0.004;
  c.background_slope_y = 0.0;
  c.background_seed = 5;

  Object a = make(Shape::kBox, 0.22, 0.16, -0.25, 0.08, 0.9, 101, 150, f);
  a.angle_rad = 0.2;
  moves(a, 0.12, 0, 0.08, 5, 0);
  Object b = make(Shape::kBox, 0.35, 0.3, 0.2, -0.1, 1.4, 102, 90, f);
  b.angle_rad = -0.1;
  moves(b, 0.05, 0, 0.3, 6, 1);
  Object d = make(Shape::kBox, 0.5, 0.4, -0.9, -0.2, 1.9, 103, 170, f);
  d.angle_rad = 0.05;
  moves(d, 0.3, 0, 0.2, 8, 2);
  Object e = make(Shape::kBox, 0.6, 0.45, 1.1, 0.35, 2.35, 104, 60, f);
  moves(e, -0.25, 0, 0.15, 7, 3);
  c.objects = {e, d, b, a};
  return c;
}

}  // namespace

SceneConfig preset(const std::string& name, int width, int height) {
  if (name == "hand") return hand(width, height);
  if (name == "boxes") return boxes(width, height);
  if (name == "static") {
    SceneConfig c = hand(width, height);
    for (Object& o : c.objects) o.amp_x_m = o.amp_y_m = o.amp_z_m = 0;
    return c;
  }
  throw Error("synthetic scene: unknown preset '" + name + "' (known: hand, boxes, static)");
}

}  // namespace dco::synthetic
