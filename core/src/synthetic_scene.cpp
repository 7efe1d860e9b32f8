// Synthetic stereo renderer: config validation, the rig's calibration, and per-frame rendering.
// Every surface is fronto-parallel (objects) or a plane with affine disparity (background), so
// each row of each view is a few convex spans painted far to near; a right pixel xr shows the
// scene point of left column xr + d, which keeps both views and the ground truth exact.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core/utility.hpp>

#include "dco/core/error.hpp"
#include "dco/core/image_turn.hpp"
#include "dco/core/synthetic_scene.hpp"

namespace dco::synthetic {
namespace {

// ---------------------------------------------------------------------------------------------
// Texture: value-noise fBm over lattice units (1 unit = the finest feature), C1 smooth so a
// subpixel shift changes the sampled intensity smoothly.

constexpr int kOctaves = 4;
// Finest octave first; strong fine detail is what a stereo matcher locks onto.
constexpr std::array<float, kOctaves> kOctaveWeight{1.0f, 0.7f, 0.5f, 0.35f};
// Standard deviation of the fBm sum: smoothstep value noise with uniform [-1, 1] lattice values
// has variance (1/3) * (26/35)^2 per octave.
const float kNoiseStd =
    std::sqrt((1.0f / 3.0f) * (26.0f / 35.0f) * (26.0f / 35.0f) *
              (kOctaveWeight[0] * kOctaveWeight[0] + kOctaveWeight[1] * kOctaveWeight[1] +
               kOctaveWeight[2] * kOctaveWeight[2] + kOctaveWeight[3] * kOctaveWeight[3]));
constexpr float kContrast = 32.0f;        // texture std dev in grey levels
constexpr double kGrainPxBackground = 4;  // background's finest feature at the image centre
constexpr float kBackgroundBrightness = 110;

std::uint32_t mix32(std::uint32_t h) {
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return h;
}

std::uint64_t mix64(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

// Uniform in [0, 1) from a hash.
float unit(std::uint32_t h) {
  return static_cast<float>(h >> 8) * (1.0f / 16777216.0f);
}

struct Texture {
  std::array<std::uint32_t, kOctaves> seed{};
  std::array<float, kOctaves> off_u{}, off_v{};
  float base = 128, gain = 0;
  std::array<float, 3> tint{1, 1, 1};  // BGR multipliers in colour mode
};

Texture make_texture(std::uint32_t seed, float brightness) {
  Texture t;
  std::uint32_t h = mix32(seed ^ 0x9e3779b9u);
  for (int k = 0; k < kOctaves; ++k) {
    t.seed[k] = h = mix32(h + 0x632be5abu);
    // Fractional lattice offsets so the octaves' grid lines never coincide.
    t.off_u[k] = 1000.0f * unit(h = mix32(h + 1));
    t.off_v[k] = 1000.0f * unit(h = mix32(h + 1));
  }
  for (float& c : t.tint) c = 0.7f + 0.6f * unit(h = mix32(h + 1));
  t.base = brightness;
  t.gain = kContrast / kNoiseStd;
  return t;
}

// Lattice value in [-1, 1).
inline float lattice(std::int32_t ix, std::int32_t iy, std::uint32_t seed) {
  std::uint32_t h = (static_cast<std::uint32_t>(ix) * 0x8da6b343u) ^
                    (static_cast<std::uint32_t>(iy) * 0xd8163841u) ^ seed;
  h ^= h >> 15;
  h *= 0x2c1b3c6du;
  h ^= h >> 12;
  h *= 0x297a2d39u;
  h ^= h >> 15;
  return static_cast<float>(static_cast<std::int32_t>(h >> 8)) * (2.0f / 16777216.0f) - 1.0f;
}

// floor() that GCC vectorizes without -fno-trapping-math. Validation keeps every shaded lattice
// coordinate below kMaxLattice, well inside int32.
constexpr double kMaxLattice = 1e8;
inline std::int32_t floor_int(float p) {
  const auto i = static_cast<std::int32_t>(p);
  return i - (p < static_cast<float>(i));
}

// Grey level (before clamping) of the texture at lattice coordinates (u, v). Branch-free so
// the span loops below vectorize.
inline float shade(const Texture& t, float u, float v) {
  float sum = 0;
  float scale = 1;
#pragma GCC unroll 4
  for (int k = 0; k < kOctaves; ++k) {
    const float pu = u * scale + t.off_u[k];
    const float pv = v * scale + t.off_v[k];
    const std::int32_t iu = floor_int(pu), iv = floor_int(pv);
    float a = pu - static_cast<float>(iu), b = pv - static_cast<float>(iv);
    a = a * a * (3 - 2 * a);
    b = b * b * (3 - 2 * b);
    const float v00 = lattice(iu, iv, t.seed[k]), v10 = lattice(iu + 1, iv, t.seed[k]);
    const float v01 = lattice(iu, iv + 1, t.seed[k]), v11 = lattice(iu + 1, iv + 1, t.seed[k]);
    const float top = v00 + a * (v10 - v00), bottom = v01 + a * (v11 - v01);
    sum += kOctaveWeight[k] * (top + b * (bottom - top));
    scale *= 0.5f;
  }
  return t.base + t.gain * sum;
}

inline std::uint8_t to_byte(float v) {
  return static_cast<std::uint8_t>(std::clamp(static_cast<std::int32_t>(v + 0.5f), 0, 255));
}

// Spans are shaded in chunks into a small stack buffer, then quantised (tinted in colour mode).
constexpr int kChunk = 256;

template <int C>
void store(std::uint8_t* __restrict out, const float* __restrict grey, int n, const Texture& t) {
  if constexpr (C == 1) {
    for (int i = 0; i < n; ++i) out[i] = to_byte(grey[i]);
  } else {
    const float b = t.tint[0], g = t.tint[1], r = t.tint[2];
    for (int i = 0; i < n; ++i) {
      out[3 * i] = to_byte(grey[i] * b);
      out[3 * i + 1] = to_byte(grey[i] * g);
      out[3 * i + 2] = to_byte(grey[i] * r);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Geometry of one frame.

struct Rig {
  int w = 0, h = 0;
  double f = 0, b = 0, cx = 0, cy = 0;
  double fb() const { return f * b; }
};

Rig rig_of(const SceneConfig& c) {
  return {c.width, c.height, c.focal_px, c.baseline_m, (c.width - 1) / 2.0, (c.height - 1) / 2.0};
}

// Background disparity d(x, y) = d0 + sx (x - cx) + sy (y - cy), left image coordinates.
struct Background {
  double d0 = 0, sx = 0, sy = 0;
  double disparity(const Rig& r, double x, double y) const {
    return d0 + sx * (x - r.cx) + sy * (y - r.cy);
  }
  // Left column whose background point lands on right column xr of row y: x - d(x, y) = xr.
  double left_x(const Rig& r, double xr, double y) const {
    return (xr + d0 - sx * r.cx + sy * (y - r.cy)) / (1 - sx);
  }
};

Background background_of(const SceneConfig& c) {
  return {c.focal_px * c.baseline_m / c.background_z_m, c.background_slope_x, c.background_slope_y};
}

// Metres per background texture unit: kGrainPxBackground pixels at the image centre.
double background_scale(const SceneConfig& c) {
  return kGrainPxBackground * c.background_z_m / c.focal_px;
}

struct BackgroundExtent {
  double d_min = INFINITY, d_max = -INFINITY;  // disparity, pixels
  double lattice = 0;                          // largest |texture coordinate|
};

// Over everything either view sees. Disparity is affine and the scene point (x - cx, y - cy) B / d
// linear-fractional, so the extremes lie at the corners of the left image or of the right
// image's back-projection, whose rows reach right_rows beyond the image's.
BackgroundExtent background_extent(const Rig& r, const Background& bg, double scale,
                                   double right_rows) {
  const double reach = std::ceil(std::abs(right_rows));
  BackgroundExtent e;
  for (double y : {-reach, r.h - 1.0 + reach})
    for (double x : {0.0, r.w - 1.0})
      for (double xl : {x, bg.left_x(r, x, y)}) {
        const double d = bg.disparity(r, xl, y);
        e.d_min = std::min(e.d_min, d);
        e.d_max = std::max(e.d_max, d);
        e.lattice = std::max(e.lattice,
                             std::max(std::abs(xl - r.cx), std::abs(y - r.cy)) * r.b / d / scale);
      }
  return e;
}

// One object at one instant, in left-image pixels.
struct Surface {
  Shape shape = Shape::kBox;
  double u = 0, v = 0;    // centre
  double c = 1, s = 0;    // cos/sin of the rotation
  double ex = 0, ey = 0;  // box: half sizes; disc: semi-axes; capsule: half segment, radius
  int y0 = 0, y1 = -1;    // rows touched (clipped to the image)
  double z = 1;
  float disp = 0, depth = 0;
  // Texture lattice coordinates are affine in the pixel: tu = au x + bu y + cu.
  double au = 0, bu = 0, cu = 0, av = 0, bv = 0, cv = 0;
  Texture tex;
};

// First / last pixel centre in [0, n) at or after / before coordinate v (n / -1 when none);
// clamped in floating point so objects far outside the view cannot overflow an int.
int pixel_at_or_after(double v, int n) {
  return static_cast<int>(std::ceil(std::clamp(v, 0.0, static_cast<double>(n))));
}
int pixel_at_or_before(double v, int n) {
  return static_cast<int>(std::floor(std::clamp(v, -1.0, static_cast<double>(n - 1))));
}

double motion(double centre, double amp, double t, const Object& o) {
  return centre + amp * std::sin(2 * std::numbers::pi * t / o.period_s + o.phase_rad);
}

Surface surface_of(const Rig& r, const Object& o, double t) {
  Surface s;
  const double x = motion(o.x_m, o.amp_x_m, t, o), y = motion(o.y_m, o.amp_y_m, t, o);
  s.z = motion(o.z_m, o.amp_z_m, t, o);
  const double k = r.f / s.z;  // pixels per metre at the object's depth
  s.shape = o.shape;
  s.u = r.cx + k * x;
  s.v = r.cy + k * y;
  s.c = std::cos(o.angle_rad);
  s.s = std::sin(o.angle_rad);
  const double hw = 0.5 * k * o.width_m, hh = 0.5 * k * o.height_m;
  double half_h = 0;  // vertical half extent of the footprint
  switch (o.shape) {
    case Shape::kBox:
      s.ex = hw;
      s.ey = hh;
      half_h = std::abs(s.s) * hw + std::abs(s.c) * hh;
      break;
    case Shape::kDisc:
      s.ex = hw;
      s.ey = hh;
      half_h = std::hypot(hw * s.s, hh * s.c);
      break;
    case Shape::kCapsule:
      s.ey = hh;  // radius
      s.ex = std::max(0.0, hw - hh);
      half_h = std::abs(s.s) * s.ex + hh;
      break;
  }
  s.y0 = pixel_at_or_after(s.v - half_h, r.h);
  s.y1 = pixel_at_or_before(s.v + half_h, r.h);
  s.disp = static_cast<float>(r.fb() / s.z);
  s.depth = static_cast<float>(r.fb() / static_cast<double>(s.disp));
  // Object-local metric coordinates: rotate (P - centre) by -angle, in texture units.
  const double inv = 1.0 / (k * o.texture_scale_m);
  const double px = -(r.cx + k * x), py = -(r.cy + k * y);  // pixel offset of the centre
  s.au = s.c * inv;
  s.bu = s.s * inv;
  s.cu = (s.c * px + s.s * py) * inv;
  s.av = -s.s * inv;
  s.bv = s.c * inv;
  s.cv = (-s.s * px + s.c * py) * inv;
  s.tex = make_texture(o.texture_seed, o.brightness);
  return s;
}

// Interval of X = x - u with lo <= a X + b <= hi, intersected into [x0, x1].
void clip_linear(double a, double b, double lo, double hi, double& x0, double& x1) {
  if (std::abs(a) < 1e-12) {
    if (b < lo || b > hi) x1 = x0 - 1;
    return;
  }
  double p = (lo - b) / a, q = (hi - b) / a;
  if (p > q) std::swap(p, q);
  x0 = std::max(x0, p);
  x1 = std::min(x1, q);
}

// Continuous left-image x-interval [x0, x1] that the surface covers on row y; false if none.
bool row_span(const Surface& s, double y, double& x0, double& x1) {
  const double dy = y - s.v;
  double lo = -INFINITY, hi = INFINITY;
  switch (s.shape) {
    case Shape::kBox:
      clip_linear(s.c, s.s * dy, -s.ex, s.ex, lo, hi);
      clip_linear(-s.s, s.c * dy, -s.ey, s.ey, lo, hi);
      break;
    case Shape::kDisc: {
      // (lx / a)^2 + (ly / b)^2 <= 1 with lx = c X + s dy, ly = -s X + c dy.
      const double ia = 1 / (s.ex * s.ex), ib = 1 / (s.ey * s.ey);
      const double qa = s.c * s.c * ia + s.s * s.s * ib;
      const double qb = s.c * s.s * dy * (ia - ib);
      const double qc = dy * dy * (s.s * s.s * ia + s.c * s.c * ib) - 1;
      const double disc = qb * qb - qa * qc;
      if (disc < 0) return false;
      const double root = std::sqrt(disc);
      lo = (-qb - root) / qa;
      hi = (-qb + root) / qa;
      break;
    }
    case Shape::kCapsule: {
      // Convex, so its row is the hull of the rows of its straight part and its two end caps.
      double slo = -INFINITY, shi = INFINITY;
      clip_linear(s.c, s.s * dy, -s.ex, s.ex, slo, shi);
      clip_linear(-s.s, s.c * dy, -s.ey, s.ey, slo, shi);
      lo = INFINITY;
      hi = -INFINITY;
      if (slo <= shi) {
        lo = slo;
        hi = shi;
      }
      for (double sign : {-1.0, 1.0}) {
        const double ex = sign * s.ex * s.c, ey = sign * s.ex * s.s;
        const double r2 = s.ey * s.ey - (dy - ey) * (dy - ey);
        if (r2 < 0) continue;
        const double half = std::sqrt(r2);
        lo = std::min(lo, ex - half);
        hi = std::max(hi, ex + half);
      }
      break;
    }
  }
  if (!(lo <= hi)) return false;
  x0 = s.u + lo;
  x1 = s.u + hi;
  return true;
}

// ---------------------------------------------------------------------------------------------
// Rows.

struct Frame {
  Rig rig;
  Background bg;
  Texture bg_tex;
  double bg_scale = 1;         // metres per background texture unit
  std::vector<Surface> order;  // far to near
};

// The background row of one view; the ground-truth rows are written for the left view only.
// y: the scene row (fractional in a right view whose rows are off, SceneConfig::right_rows).
template <int C>
void background_row(const Frame& fr, double y, bool right, std::uint8_t* out, float* disp,
                    float* depth) {
  const Rig& r = fr.rig;
  const float cx = static_cast<float>(r.cx), yc = static_cast<float>(y - r.cy);
  const float dy = static_cast<float>(fr.bg.d0 + fr.bg.sy * (y - r.cy));
  const float sx = static_cast<float>(fr.bg.sx);
  // Left column of the scene point: (x + k) * m; k = 0, m = 1 (exactly x) in the left view.
  const float k =
      right ? static_cast<float>(fr.bg.d0 - fr.bg.sx * r.cx + fr.bg.sy * (y - r.cy)) : 0.0f;
  const float m = right ? static_cast<float>(1 / (1 - fr.bg.sx)) : 1.0f;
  const float bs = static_cast<float>(r.b / fr.bg_scale);
  const Texture t = fr.bg_tex;
  alignas(64) float grey[kChunk];
  for (int x0 = 0; x0 < r.w; x0 += kChunk) {
    const int n = std::min(kChunk, r.w - x0);
    for (int i = 0; i < n; ++i) {
      const float xl = (static_cast<float>(x0 + i) + k) * m;
      // Scene point (X, Y) = (x - cx, y - cy) * B / d, in texture units.
      const float units = bs / (dy + sx * (xl - cx));
      grey[i] = shade(t, (xl - cx) * units, yc * units);
    }
    store<C>(out + x0 * C, grey, n, t);
  }
  if (right) return;
  const double fb = r.fb();
  for (int x = 0; x < r.w; ++x) {
    const float d = dy + sx * (static_cast<float>(x) - cx);
    disp[x] = d;
    depth[x] = static_cast<float>(fb / static_cast<double>(d));
  }
}

template <int C>
void object_row(const Frame& fr, const Surface& s, double y, bool right, std::uint8_t* out,
                float* disp, float* depth) {
  double a = 0, b = 0;
  if (!row_span(s, y, a, b)) return;
  const double shift = right ? s.disp : 0.0;
  const int first = pixel_at_or_after(a - shift, fr.rig.w);
  const int last = pixel_at_or_before(b - shift, fr.rig.w);
  if (first > last) return;
  const float xoff = right ? s.disp : 0.0f;
  const float au = static_cast<float>(s.au), av = static_cast<float>(s.av);
  const float ru = static_cast<float>(s.bu * y + s.cu), rv = static_cast<float>(s.bv * y + s.cv);
  const Texture t = s.tex;
  alignas(64) float grey[kChunk];
  for (int x0 = first; x0 <= last; x0 += kChunk) {
    const int n = std::min(kChunk, last + 1 - x0);
    for (int i = 0; i < n; ++i) {
      const float xl = static_cast<float>(x0 + i) + xoff;  // same scene point in both views
      grey[i] = shade(t, au * xl + ru, av * xl + rv);
    }
    store<C>(out + x0 * C, grey, n, t);
  }
  if (right) return;
  std::fill(disp + first, disp + last + 1, s.disp);
  std::fill(depth + first, depth + last + 1, s.depth);
}

// Row y of a view, which shows the scene row y - rows (rows: 0 in the left view).
template <int C>
void render_row(const Frame& fr, int y, bool right, double rows, Image<std::uint8_t>& img,
                Image<float>& disp, Image<float>& depth) {
  std::uint8_t* row = img.row(y);
  float* drow = right ? nullptr : disp.row(y);
  float* zrow = right ? nullptr : depth.row(y);
  const double scene_y = y - rows;
  background_row<C>(fr, scene_y, right, row, drow, zrow);
  // The rows a surface touches are clipped to the image: a moved view may reach a row beyond.
  const double reach = std::ceil(std::abs(rows));
  for (const Surface& s : fr.order)
    if (scene_y >= s.y0 - reach && scene_y <= s.y1 + reach)
      object_row<C>(fr, s, scene_y, right, row, drow, zrow);
}

// ---------------------------------------------------------------------------------------------
// Sensor noise: a table of standard-normal quantiles indexed by random bits is exact enough
// for 8-bit pixels and far cheaper than Box-Muller.

constexpr int kGaussBits = 12;

const std::array<float, 1 << kGaussBits>& gaussian_table() {
  static const auto table = [] {
    std::array<float, 1 << kGaussBits> q{};
    for (std::size_t i = 0; i < q.size(); ++i) {
      const double p = (static_cast<double>(i) + 0.5) / static_cast<double>(q.size());
      double lo = -8, hi = 8;  // bisect Phi(z) = p
      for (int it = 0; it < 48; ++it) {
        const double mid = 0.5 * (lo + hi);
        (0.5 * std::erfc(-mid / std::numbers::sqrt2) < p ? lo : hi) = mid;
      }
      q[i] = static_cast<float>(0.5 * (lo + hi));
    }
    return q;
  }();
  return table;
}

// Row y of a view's noise: its own random stream, so rows may be rendered in any order.
void add_noise_row(Image<std::uint8_t>& img, double sigma, std::int64_t index, int view, int y) {
  const auto& gauss = gaussian_table();
  const float s = static_cast<float>(sigma);
  const std::uint64_t frame_seed =
      mix64((static_cast<std::uint64_t>(static_cast<std::uint32_t>(index)) << 1) | view);
  const int n = img.width() * img.channels();
  constexpr int kPerDraw = 64 / kGaussBits;
  std::uint64_t state = mix64(frame_seed ^ (static_cast<std::uint64_t>(y) << 32));
  std::uint8_t* row = img.row(y);
  for (int i = 0; i < n;) {
    state += 0x9e3779b97f4a7c15ull;
    std::uint64_t bits = mix64(state);
    for (int j = 0; j < kPerDraw && i < n; ++j, ++i, bits >>= kGaussBits) {
      const float v = static_cast<float>(row[i]) + s * gauss[bits & ((1u << kGaussBits) - 1)];
      row[i] = static_cast<std::uint8_t>(std::clamp(v, 0.0f, 255.0f) + 0.5f);
    }
  }
}

// Row y of a view darkened by 1 - k r^2 (r = 1 at the half-diagonal from the centre).
void fall_off_row(Image<std::uint8_t>& img, double k, int y) {
  const double cx = 0.5 * (img.width() - 1), cy = 0.5 * (img.height() - 1);
  const double inverse = 1.0 / (cx * cx + cy * cy), dy2 = (y - cy) * (y - cy);
  const int c = img.channels();
  std::uint8_t* row = img.row(y);
  for (int x = 0; x < img.width(); ++x) {
    const auto v = static_cast<float>(1.0 - k * ((x - cx) * (x - cx) + dy2) * inverse);
    for (int i = x * c; i < (x + 1) * c; ++i) row[i] = static_cast<std::uint8_t>(v * row[i] + 0.5f);
  }
}

void scale_row(Image<std::uint8_t>& img, double gain, double offset, int y) {
  const auto g = static_cast<float>(gain), o = static_cast<float>(offset);
  const int n = img.width() * img.channels();
  std::uint8_t* row = img.row(y);
  for (int i = 0; i < n; ++i)
    row[i] = static_cast<std::uint8_t>(std::clamp(g * row[i] + o, 0.0f, 255.0f) + 0.5f);
}

// ---------------------------------------------------------------------------------------------
// Validation.

bool finite(double v) {
  return std::isfinite(v);
}

[[noreturn]] void fail(const std::string& msg) {
  throw Error("synthetic scene: " + msg);
}

void validate_object(const SceneConfig& c, std::size_t i, double bg_nearest_m) {
  const Object& o = c.objects[i];
  const std::string name = fmt::format("object {}", i);
  for (double v : {o.width_m, o.height_m, o.angle_rad, o.x_m, o.y_m, o.z_m, o.amp_x_m, o.amp_y_m,
                   o.amp_z_m, o.period_s, o.phase_rad, o.texture_scale_m})
    if (!finite(v)) fail(name + " has a non-finite parameter");
  if (o.width_m <= 0 || o.height_m <= 0)
    fail(fmt::format("{}: size {} x {} m must be positive", name, o.width_m, o.height_m));
  if (o.period_s <= 0) fail(fmt::format("{}: period_s {} must be positive", name, o.period_s));
  if (o.texture_scale_m <= 0)
    fail(fmt::format("{}: texture_scale_m {} must be positive", name, o.texture_scale_m));
  // Shaded points lie within the shape, so this bounds the texture's lattice coordinates.
  if (std::hypot(o.width_m, o.height_m) / o.texture_scale_m > kMaxLattice)
    fail(fmt::format("{}: texture_scale_m {} is too fine for its size", name, o.texture_scale_m));
  const double near = o.z_m - std::abs(o.amp_z_m), far = o.z_m + std::abs(o.amp_z_m);
  if (near <= 0.1)
    fail(fmt::format("{}: depth comes within {} m of the camera (must stay beyond 0.1 m)", name,
                     near));
  if (far >= bg_nearest_m)
    fail(fmt::format("{}: depth reaches {} m, not in front of the background (nearest {:.3f} m)",
                     name, far, bg_nearest_m));
}

void validate(const SceneConfig& c) {
  if (c.width < kMinSide || c.width > kMaxSide || c.height < kMinSide || c.height > kMaxSide)
    fail(fmt::format("resolution {}x{} is outside {}..{}", c.width, c.height, kMinSide, kMaxSide));
  if (!finite(c.focal_px) || c.focal_px <= 0)
    fail(fmt::format("focal_px {} must be positive", c.focal_px));
  if (!finite(c.baseline_m) || c.baseline_m <= 0)
    fail(fmt::format("baseline_m {} must be positive", c.baseline_m));
  if (!finite(c.fps) || c.fps <= 0) fail(fmt::format("fps {} must be positive", c.fps));
  if (!finite(c.noise_sigma) || c.noise_sigma < 0)
    fail(fmt::format("noise_sigma {} must be >= 0", c.noise_sigma));
  if (!finite(c.right_gain) || c.right_gain < 0.25 || c.right_gain > 4)
    fail(fmt::format("right_gain {} must be within [0.25, 4]", c.right_gain));
  if (!finite(c.right_offset) || std::abs(c.right_offset) > 128)
    fail(fmt::format("right_offset {} must be within [-128, 128]", c.right_offset));
  if (!finite(c.right_rows) || std::abs(c.right_rows) > 8)
    fail(fmt::format("right_rows {} must be within [-8, 8]", c.right_rows));
  if (!finite(c.right_roll_deg) || std::abs(c.right_roll_deg) > 1)
    fail(fmt::format("right_roll_deg {} must be within [-1, 1]", c.right_roll_deg));
  if (!finite(c.lens_falloff) || c.lens_falloff < 0 || c.lens_falloff > 0.75)
    fail(fmt::format("lens_falloff {} must be within [0, 0.75]", c.lens_falloff));
  if (!finite(c.background_z_m) || c.background_z_m <= 0.1)
    fail(fmt::format("background_z_m {} must be more than 0.1 m", c.background_z_m));
  if (!finite(c.background_slope_x) || !finite(c.background_slope_y))
    fail("background slopes must be finite");
  if (std::abs(c.background_slope_x) >= 1)
    fail(fmt::format("background_slope_x {} must be within (-1, 1)", c.background_slope_x));
  const Rig r = rig_of(c);
  const BackgroundExtent e =
      background_extent(r, background_of(c), background_scale(c), c.right_rows);
  if (!(e.d_min > 0))
    fail(
        fmt::format("background disparity falls to {:.3f} px inside the view (it must stay "
                    "positive: reduce the background slopes)",
                    e.d_min));
  if (e.lattice > kMaxLattice)
    fail(
        fmt::format("background is nearly edge-on (disparity falls to {:.3g} px): reduce the "
                    "background slopes",
                    e.d_min));
  if (r.fb() / e.d_max <= 0.1)
    fail(fmt::format("background comes within {:.3f} m of the camera (must stay beyond 0.1 m)",
                     r.fb() / e.d_max));
  for (std::size_t i = 0; i < c.objects.size(); ++i) validate_object(c, i, r.fb() / e.d_max);
}

}  // namespace

int covering_max_disparity(const SceneConfig& c) {
  validate(c);
  const Rig r = rig_of(c);
  // The background's nearest point: a tilted one comes nearer than at the image centre.
  double z_min =
      r.fb() / background_extent(r, background_of(c), background_scale(c), c.right_rows).d_max;
  for (const Object& o : c.objects) z_min = std::min(z_min, o.z_m - std::abs(o.amp_z_m));
  return static_cast<int>(std::ceil(1.1 * r.fb() / z_min));
}

SceneRenderer::SceneRenderer(SceneConfig config) : config_(std::move(config)) {
  validate(config_);
}

StereoCalibration SceneRenderer::calibration() const {
  const Rig r = rig_of(config_);
  StereoCalibration calib;
  calib.is_rectified = true;
  calib.rectified = {r.w, r.h, r.f, r.cx, r.cx, r.cy, r.b};
  for (CameraIntrinsics* cam : {&calib.left, &calib.right}) {
    cam->model = CameraModel::kPinhole;
    cam->width = r.w;
    cam->height = r.h;
    cam->fx = cam->fy = r.f;
    cam->cx = r.cx;
    cam->cy = r.cy;
    cam->distortion.clear();
  }
  calib.translation = {-r.b, 0, 0};
  calib.source = "synthetic scene";
  return calib;
}

void SceneRenderer::render(std::int64_t index, StereoSample& out) const {
  const SceneConfig& c = config_;
  const int channels = c.color ? 3 : 1;
  out.index = index;
  out.time_s = static_cast<double>(index) / c.fps;
  out.left.resize(c.width, c.height, channels);
  out.right.resize(c.width, c.height, channels);
  out.disparity.resize(c.width, c.height);
  out.depth_m.resize(c.width, c.height);

  Frame fr;
  fr.rig = rig_of(c);
  fr.bg = background_of(c);
  fr.bg_tex = make_texture(c.background_seed, kBackgroundBrightness);
  fr.bg_scale = background_scale(c);
  fr.order.reserve(c.objects.size());
  for (const Object& o : c.objects) fr.order.push_back(surface_of(fr.rig, o, out.time_s));
  // Painter's order; stable so equal depths resolve the same way every frame.
  std::stable_sort(fr.order.begin(), fr.order.end(),
                   [](const Surface& a, const Surface& b) { return a.z > b.z; });

  // Every row of both views is rendered from the scene alone, so the rows are shared out over
  // OpenCV's threads (one where the runtime keeps OpenCV to one): a 1280x720 pair takes about
  // 30 ms on one core, more than a 60 fps source's period.
  gaussian_table();  // made once, before any thread reads it
  // A turned right view is rendered upright into a frame of its own and turned into out.right;
  // its noise and levels come after the turn, as a sensor's do.
  const bool turned = c.right_roll_deg != 0.0;
  // The calling thread's frame, named by reference: inside the workers' lambda a thread_local
  // would be each worker's own.
  thread_local Image<std::uint8_t> upright_frame;
  Image<std::uint8_t>& upright = upright_frame;
  if (turned) upright.resize(c.width, c.height, channels);
  const auto sensor_rows = [&](Image<std::uint8_t>& img, bool right, int y) {
    if (c.lens_falloff > 0) fall_off_row(img, c.lens_falloff, y);
    if (c.noise_sigma > 0) add_noise_row(img, c.noise_sigma, index, right ? 1 : 0, y);
    if (right && (c.right_gain != 1.0 || c.right_offset != 0.0))
      scale_row(img, c.right_gain, c.right_offset, y);
  };
  cv::parallel_for_(cv::Range(0, c.height), [&](const cv::Range& rows) {
    for (const bool right : {false, true}) {
      Image<std::uint8_t>& img = right ? (turned ? upright : out.right) : out.left;
      const double moved_rows = right ? c.right_rows : 0.0;
      for (int y = rows.start; y < rows.end; ++y) {
        if (channels == 1)
          render_row<1>(fr, y, right, moved_rows, img, out.disparity, out.depth_m);
        else
          render_row<3>(fr, y, right, moved_rows, img, out.disparity, out.depth_m);
        if (!(right && turned)) sensor_rows(img, right, y);
      }
    }
  });
  if (!turned) return;
  // The scene at the upright view's pixel p lies at centre + R(roll) (p - centre) in out.right.
  turn_about_centre(upright.cview(), -c.right_roll_deg * std::numbers::pi / 180.0, 0.0, out.right);
  cv::parallel_for_(cv::Range(0, c.height), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) sensor_rows(out.right, true, y);
  });
}

}  // namespace dco::synthetic
