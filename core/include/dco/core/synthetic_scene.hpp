#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "dco/core/calibration.hpp"
#include "dco/core/image.hpp"

namespace dco::synthetic {

// The sides a scene may have, px.
inline constexpr int kMinSide = 16;
inline constexpr int kMaxSide = 8192;

// A procedurally textured stereo sequence with exact ground truth: fronto-parallel objects
// (boxes, discs, thin capsules like fingers) moving in front of a slanted textured background,
// seen by an ideal rectified stereo pair. Rendering is point-sampled at pixel centres from
// continuous textures anchored to each object, so left, right and ground truth agree exactly
// (up to the optional sensor noise) at any resolution and any subpixel disparity.

enum class Shape { kBox, kDisc, kCapsule };

struct Object {
  Shape shape = Shape::kBox;
  // Size in metres at the object's depth (capsule: length and diameter; disc: diameter twice).
  double width_m = 0.1, height_m = 0.1;
  double angle_rad = 0;  // rotation in the image plane (0: width along +x)
  // Centre position (metres, camera frame of the left camera) as a function of time:
  // p(t) = centre + amplitude * sin(2π t / period + phase), per axis.
  double x_m = 0, y_m = 0, z_m = 1;
  double amp_x_m = 0, amp_y_m = 0, amp_z_m = 0;
  double period_s = 4, phase_rad = 0;
  std::uint32_t texture_seed = 1;
  double texture_scale_m = 0.01;  // size of the finest texture features
  std::uint8_t brightness = 128;  // mean grey level
};

struct SceneConfig {
  int width = 1280;
  int height = 720;
  double focal_px = 700;     // both cameras; principal point at the image centre
  double baseline_m = 0.12;  // INDEMIND-like
  double fps = 30;
  // Background: a plane with depth z = background_z_m at the image centre, tilted so its
  // disparity changes linearly by background_slope_x / _y pixels per pixel.
  double background_z_m = 3.0;
  double background_slope_x = 0.0;
  double background_slope_y = 0.01;
  std::uint32_t background_seed = 7;
  std::vector<Object> objects;
  double noise_sigma = 1.0;  // Gaussian sensor noise (grey levels), deterministic per frame
  bool color = false;        // BGR output instead of grey
  // The right camera's levels against the left's, as a cheap pair's two sensors differ: a level
  // v of the right view becomes right_gain * v + right_offset (rounded, clamped to 0..255).
  double right_gain = 1.0;
  double right_offset = 0.0;
  // The right camera's scene lies right_rows rows below the left's (within [-8, 8]), as a
  // cheap module's rectification drifts: its row y shows the scene row y - right_rows, rendered
  // there (not interpolated). The ground truth, of the left view, does not change.
  double right_rows = 0.0;
  // The right camera turned by right_roll_deg degrees (within [-1, 1]) about the image centre
  // against the left, as a module's mount flexes: its scene at column x lies tan(roll) * (x - xc)
  // rows lower (and a row's scene tan(roll) * (y - yc) columns further left). Rendered upright,
  // then turned (bilinear), then its noise and levels.
  double right_roll_deg = 0.0;
  // Both lenses darken towards the corners, as one lens model does: a level v at radius r becomes
  // v (1 - lens_falloff r^2), r = 1 at the half-diagonal from the image centre (within
  // [0, 0.75]; each view about its own centre, before the sensor's noise and levels).
  double lens_falloff = 0.0;
};

// Named scenes: "hand" (four finger capsules and a palm disc sweeping across a box in front of
// a wall), "boxes" (boxes at several depths moving sideways and in depth), "static" (like "hand"
// but nothing moves). Throws dco::Error for an unknown name.
SceneConfig preset(const std::string& name, int width = 1280, int height = 720);

// A disparity search range that covers the scene: the disparity of the nearest depth any object
// (or the background) reaches, plus 10 %. Throws dco::Error for an invalid config.
int covering_max_disparity(const SceneConfig& config);

struct StereoSample {
  std::int64_t index = 0;
  double time_s = 0;
  Image<std::uint8_t> left, right;  // 1 or 3 channels
  Image<float> disparity;           // left view, pixels, every pixel set
  Image<float> depth_m;             // left view, metres, every pixel set
};

class SceneRenderer {
 public:
  explicit SceneRenderer(SceneConfig config);  // throws dco::Error on an invalid config

  const SceneConfig& config() const { return config_; }
  // The rig: already rectified, f = focal_px, principal point at the centre, baseline.
  StereoCalibration calibration() const;
  // Renders frame `index` (time index / fps) into `out`, reusing its buffers. Deterministic:
  // the same index gives the same bytes.
  void render(std::int64_t index, StereoSample& out) const;

 private:
  SceneConfig config_;
};

}  // namespace dco::synthetic
