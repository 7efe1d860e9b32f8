#include "dco/core/synthetic_scene.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core/utility.hpp>

#include "dco/core/error.hpp"
#include "support/same_bytes.hpp"

namespace dco::synthetic {
namespace {

using dco::testing::same_bytes;

SceneConfig quiet(SceneConfig c) {
  c.noise_sigma = 0;
  return c;
}

StereoSample render(const SceneConfig& c, std::int64_t index) {
  StereoSample s;
  SceneRenderer(c).render(index, s);
  return s;
}

bool same_sample(const StereoSample& a, const StereoSample& b) {
  return same_bytes(a.left, b.left) && same_bytes(a.right, b.right) &&
         same_bytes(a.disparity, b.disparity) && same_bytes(a.depth_m, b.depth_m);
}

double bilinear_row(const Image<std::uint8_t>& img, double x, int y) {
  const int x0 = static_cast<int>(std::floor(x));
  const double t = x - x0;
  return (1 - t) * img.at(x0, y) + t * img.at(x0 + 1, y);
}

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(p * static_cast<double>(v.size() - 1))];
}

// True when a nearer surface lands within `margin` pixels of xr in the right view (the point is
// occluded there, or bilinear interpolation would straddle a depth edge).
bool near_occluder(const StereoSample& s, int y, double xr, float d, double margin) {
  for (int x = 0; x < s.disparity.width(); ++x) {
    const float dx = s.disparity.at(x, y);
    if (dx > d + 0.01f && std::abs(x - dx - xr) <= margin) return true;
  }
  return false;
}

struct Errors {
  std::vector<double> all, objects;  // |left - right| in grey levels
};

// Left pixels whose right-view correspondence (from the ground truth) is visible, on the same
// smooth surface, and inside the image: left(x) vs bilinear right(x - d + shift).
Errors correspondence_errors(const StereoSample& s, double shift, int samples) {
  std::mt19937 rng(123);
  std::uniform_int_distribution<int> rx(2, s.left.width() - 3), ry(0, s.left.height() - 1);
  const float d_background_max = 40;  // every preset's wall is below this at 1280
  Errors e;
  for (int i = 0; i < samples; ++i) {
    const int x = rx(rng), y = ry(rng);
    const float d = s.disparity.at(x, y);
    bool smooth = true;
    for (int k = -2; k <= 2; ++k) smooth &= std::abs(s.disparity.at(x + k, y) - d) < 0.2f;
    const double xr = x - d + shift;
    if (!smooth || xr < 0 || xr > s.right.width() - 2 || near_occluder(s, y, xr, d, 2.5)) continue;
    const double err = std::abs(s.left.at(x, y) - bilinear_row(s.right, xr, y));
    e.all.push_back(err);
    if (d > d_background_max) e.objects.push_back(err);
  }
  return e;
}

TEST(SyntheticScene, RightViewMatchesLeftAtGroundTruthDisparity) {
  for (const char* name : {"hand", "boxes"}) {
    SCOPED_TRACE(name);
    const StereoSample s = render(quiet(preset(name)), 17);
    const Errors e = correspondence_errors(s, 0, 20000);
    ASSERT_GT(e.all.size(), 10000u);
    ASSERT_GT(e.objects.size(), 500u);
    // Residuals are bilinear interpolation of a smooth texture plus 8-bit rounding.
    EXPECT_LT(percentile(e.all, 0.5), 1.0);
    EXPECT_LT(percentile(e.all, 0.95), 3.0);
    EXPECT_LT(percentile(e.all, 0.99), 5.0);
    EXPECT_LT(percentile(e.objects, 0.5), 1.0);
    EXPECT_LT(percentile(e.objects, 0.95), 3.0);
    // A disparity off by one pixel is clearly worse: the texture carries the disparity.
    const Errors off = correspondence_errors(s, 1.0, 20000);
    EXPECT_GT(percentile(off.all, 0.5), 4.0);
    EXPECT_GT(percentile(off.objects, 0.5), 4.0);
  }
}

TEST(SyntheticScene, IntegerDisparitiesGiveIdenticalPixels) {
  // f * B = 50, so depths 2.5, 1.25, 0.625 and 0.5 m give disparities 20, 40, 80 and 100 px.
  SceneConfig c;
  c.width = 320;
  c.height = 200;
  c.focal_px = 100;
  c.baseline_m = 0.5;
  c.background_z_m = 2.5;
  c.background_slope_x = c.background_slope_y = 0;
  c.noise_sigma = 0;
  // Side by side, so every surface the right view shows is visible in the left view too.
  Object box;
  box.shape = Shape::kBox;
  box.width_m = box.height_m = 1.0;
  box.angle_rad = 0.3;
  box.z_m = 1.25;
  box.x_m = -1.0;
  box.texture_scale_m = 0.05;
  Object disc = box;
  disc.shape = Shape::kDisc;
  disc.width_m = 0.3;
  disc.height_m = 0.5;
  disc.z_m = 0.625;
  disc.x_m = 0.15;
  disc.texture_seed = 9;
  disc.texture_scale_m = 0.02;
  Object finger = disc;
  finger.shape = Shape::kCapsule;
  finger.width_m = 0.6;
  finger.height_m = 0.05;
  finger.angle_rad = 1.2;
  finger.z_m = 0.5;
  finger.x_m = 0.45;
  finger.texture_seed = 4;
  c.objects = {box, disc, finger};
  const StereoSample s = render(c, 5);

  long compared = 0, objects = 0;
  for (int y = 0; y < c.height; ++y) {
    // The surface each right pixel shows is the one with the largest disparity landing there.
    std::vector<float> shown(c.width, 0);
    for (int x = 0; x < c.width; ++x) {
      const float d = s.disparity.at(x, y);
      ASSERT_EQ(d, std::round(d));
      const int xr = x - static_cast<int>(d);
      if (xr >= 0) shown[xr] = std::max(shown[xr], d);
    }
    for (int x = 0; x < c.width; ++x) {
      const float d = s.disparity.at(x, y);
      const int xr = x - static_cast<int>(d);
      if (xr < 0 || shown[xr] != d) continue;
      ASSERT_EQ(s.left.at(x, y), s.right.at(xr, y)) << "at " << x << "," << y << " d " << d;
      ++compared;
      objects += d > 20;
    }
  }
  EXPECT_GT(compared, c.width * c.height / 2);
  EXPECT_GT(objects, 3000);
}

TEST(SyntheticScene, GroundTruthIsFinitePositiveAndDepthIsFocalBaselineOverDisparity) {
  for (const char* name : {"hand", "boxes", "static"}) {
    const SceneConfig c = preset(name, 640, 360);
    const StereoSample s = render(c, 40);
    const double fb = c.focal_px * c.baseline_m;
    for (int y = 0; y < c.height; ++y)
      for (int x = 0; x < c.width; ++x) {
        const float d = s.disparity.at(x, y), z = s.depth_m.at(x, y);
        ASSERT_TRUE(std::isfinite(d) && d > 0) << name << " " << x << "," << y;
        ASSERT_TRUE(std::isfinite(z) && z > 0.1f) << name << " " << x << "," << y;
        ASSERT_EQ(z, static_cast<float>(fb / static_cast<double>(d))) << name;
      }
  }
}

TEST(SyntheticScene, CoveringMaxDisparityCoversEveryFrameWithLittleToSpare) {
  for (const char* name : {"hand", "boxes", "static"}) {
    const SceneConfig config = preset(name, 320, 180);
    const int range = covering_max_disparity(config);
    float largest = 0;
    for (int i = 0; i < 60; i += 3) {
      const StereoSample s = render(config, i);
      for (int y = 0; y < s.disparity.height(); ++y)
        for (int x = 0; x < s.disparity.width(); ++x)
          largest = std::max(largest, s.disparity.at(x, y));
    }
    EXPECT_LE(largest, static_cast<float>(range)) << name;
    EXPECT_GT(largest, 0.75f * static_cast<float>(range)) << name;  // not a wild overestimate
  }
  // A tilted background alone: its nearest point is not at the image centre.
  for (const double slope : {0.03, -0.03}) {
    SceneConfig config = preset("static", 320, 180);
    config.objects.clear();
    config.background_slope_y = slope;
    config.background_slope_x = slope / 3;
    const int range = covering_max_disparity(config);
    const StereoSample s = render(config, 0);
    float largest = 0;
    for (int y = 0; y < s.disparity.height(); ++y)
      for (int x = 0; x < s.disparity.width(); ++x)
        largest = std::max(largest, s.disparity.at(x, y));
    EXPECT_LE(largest, static_cast<float>(range)) << slope;
  }
}

TEST(SyntheticScene, CloserObjectHasLargerDisparity) {
  SceneConfig c = quiet(preset("static", 640, 360));
  c.background_slope_x = c.background_slope_y = 0;
  Object box;
  box.width_m = box.height_m = 0.4;
  box.z_m = 1.0;
  box.x_m = 0.8;  // right of the hand
  c.objects.push_back(box);
  const StereoSample s = render(c, 0);
  const double fb = c.focal_px * c.baseline_m;
  const int bx = static_cast<int>(std::lround((c.width - 1) / 2.0 + c.focal_px * 0.8));
  const int by = (c.height - 1) / 2;
  EXPECT_NEAR(s.disparity.at(bx, by), fb / 1.0, 1e-4);
  EXPECT_NEAR(s.depth_m.at(bx, by), 1.0, 1e-5);
  EXPECT_NEAR(s.disparity.at(c.width - 2, 2), fb / c.background_z_m, 1e-4);  // wall corner
  EXPECT_GT(s.disparity.at(bx, by), s.disparity.at(c.width - 2, 2));
  // The nearest surface anywhere is the nearest object.
  double nearest = 1e9;
  for (const Object& o : c.objects) nearest = std::min(nearest, o.z_m);
  float dmax = 0;
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) dmax = std::max(dmax, s.disparity.at(x, y));
  EXPECT_NEAR(dmax, fb / nearest, 1e-3);
}

TEST(SyntheticScene, ObjectsPartlyOrFarOutsideTheViewAreClipped) {
  SceneConfig c = quiet(preset("static", 320, 180));
  c.objects.resize(1);
  c.objects[0].x_m = -1.0;  // box straddling the left border at 1.2 m
  Object far = c.objects[0];
  far.x_m = 1e9;
  far.y_m = -1e9;
  c.objects.push_back(far);
  const StereoSample s = render(c, 0);
  const float box_d = static_cast<float>(c.focal_px * c.baseline_m / 1.2);
  long box = 0;
  for (int y = 0; y < c.height; ++y) {
    ASSERT_TRUE(std::isfinite(s.disparity.at(0, y)));
    box += std::abs(s.disparity.at(0, y) - box_d) < 1e-3f;
  }
  EXPECT_GT(box, 20);  // the box covers part of the left column
}

TEST(SyntheticScene, HandMovesAndStaticDoesNot) {
  const StereoSample h0 = render(quiet(preset("hand", 640, 360)), 0);
  const StereoSample h30 = render(quiet(preset("hand", 640, 360)), 30);
  EXPECT_FALSE(same_bytes(h0.left, h30.left));
  EXPECT_FALSE(same_bytes(h0.disparity, h30.disparity));
  EXPECT_DOUBLE_EQ(h30.time_s, 1.0);
  EXPECT_EQ(h30.index, 30);
  long moved = 0;
  for (int y = 0; y < h0.disparity.height(); ++y)
    for (int x = 0; x < h0.disparity.width(); ++x)
      moved += h0.disparity.at(x, y) != h30.disparity.at(x, y);
  EXPECT_GT(moved, 1000);  // objects, not a stray pixel

  const StereoSample s0 = render(quiet(preset("static", 640, 360)), 0);
  const StereoSample s30 = render(quiet(preset("static", 640, 360)), 30);
  EXPECT_TRUE(same_sample(s0, s30));
  // Noise differs per frame but the ground truth does not.
  const StereoSample n0 = render(preset("static", 640, 360), 0);
  const StereoSample n30 = render(preset("static", 640, 360), 30);
  EXPECT_FALSE(same_bytes(n0.left, n30.left));
  EXPECT_TRUE(same_bytes(n0.disparity, n30.disparity));
}

// A source runs for weeks: frame 2^24 (6.5 days at 30 fps) and frames past 2^31 go on with the
// scene's motion instead of starting it again or running time backwards.
TEST(SyntheticScene, FramesOfALongRunKeepTheirTime) {
  const SceneConfig c = quiet(preset("hand", 640, 360));
  const std::int64_t day6 = std::int64_t{1} << 24, past_int = (std::int64_t{1} << 31) + 7;
  const StereoSample first = render(c, 0);
  const StereoSample later = render(c, day6);
  EXPECT_EQ(later.index, day6);
  EXPECT_DOUBLE_EQ(later.time_s, static_cast<double>(day6) / c.fps);
  EXPECT_FALSE(same_bytes(first.disparity, later.disparity));
  const StereoSample far = render(c, past_int);
  EXPECT_EQ(far.index, past_int);
  EXPECT_GT(far.time_s, later.time_s);
  // One frame later is one frame's motion on: most of the hand stays where it was.
  const StereoSample next = render(c, past_int + 1);
  long moved = 0;
  for (int y = 0; y < far.disparity.height(); ++y)
    for (int x = 0; x < far.disparity.width(); ++x)
      moved += std::abs(far.disparity.at(x, y) - next.disparity.at(x, y)) > 1.0f;
  EXPECT_GT(moved, 0);
  EXPECT_LT(moved, far.disparity.width() * far.disparity.height() / 20);
}

TEST(SyntheticScene, DeterministicIncludingNoise) {
  const SceneConfig c = preset("boxes", 320, 180);
  ASSERT_GT(c.noise_sigma, 0);
  StereoSample a, b;
  SceneRenderer(c).render(12, a);
  SceneRenderer r(c);
  r.render(3, b);
  r.render(12, b);
  EXPECT_TRUE(same_sample(a, b));
  // Left and right noise are independent: they differ from the noise-free views differently.
  const StereoSample clean = render(quiet(c), 12);
  EXPECT_FALSE(same_bytes(a.left, clean.left));
  EXPECT_FALSE(same_bytes(a.right, clean.right));
}

// The rows are shared out over OpenCV's threads: any number of them renders the same bytes.
TEST(SyntheticScene, RowsOnAnyNumberOfThreadsGiveTheSameBytes) {
  const int original = cv::getNumThreads();
  for (const char* name : {"hand", "boxes"}) {
    SceneConfig c = preset(name, 320, 180);
    c.color = std::string(name) == "boxes";
    cv::setNumThreads(1);
    const StereoSample one = render(c, 9);
    for (int threads : {2, 3, 8}) {
      cv::setNumThreads(threads);
      EXPECT_TRUE(same_sample(render(c, 9), one)) << name << " on " << threads << " threads";
    }
  }
  cv::setNumThreads(original);
}

TEST(SyntheticScene, NoiseHasTheConfiguredSigma) {
  SceneConfig c = preset("static", 640, 360);
  c.noise_sigma = 3;
  const StereoSample noisy = render(c, 1);
  const StereoSample clean = render(quiet(c), 1);
  double sum = 0, sum2 = 0, corr = 0;
  long n = 0;
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) {
      const int a = clean.left.at(x, y), r = clean.right.at(x, y);
      if (a < 20 || a > 235 || r < 20 || r > 235) continue;  // away from clipping
      const double el = noisy.left.at(x, y) - a, er = noisy.right.at(x, y) - r;
      sum += el;
      sum2 += el * el;
      corr += el * er;
      ++n;
    }
  ASSERT_GT(n, 100000);
  EXPECT_NEAR(sum / n, 0, 0.05);
  EXPECT_NEAR(std::sqrt(sum2 / n), std::hypot(3.0, std::sqrt(1.0 / 12)), 0.15);
  EXPECT_NEAR(corr / sum2, 0, 0.02);  // independent views
}

TEST(SyntheticScene, TextureHasStereoContrast) {
  const SceneConfig c = quiet(preset("boxes", 640, 360));
  const StereoSample s = render(c, 0);
  // Background-only window in the top-right corner.
  double sum = 0, sum2 = 0;
  long n = 0;
  for (int y = 0; y < 60; ++y)
    for (int x = c.width - 120; x < c.width; ++x) {
      ASSERT_LT(s.disparity.at(x, y), 30.0f);  // still the wall
      sum += s.left.at(x, y);
      sum2 += s.left.at(x, y) * s.left.at(x, y);
      ++n;
    }
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_GT(sd, 20);
  EXPECT_LT(sd, 45);
}

// Median horizontal run, in pixels, of ground-truth disparity `d` on rows where it appears.
double median_run(const Image<float>& disp, float d) {
  std::vector<double> runs;
  for (int y = 0; y < disp.height(); ++y) {
    int run = 0;
    for (int x = 0; x <= disp.width(); ++x) {
      if (x < disp.width() && std::abs(disp.at(x, y) - d) < 1e-3f) {
        ++run;
      } else if (run > 0) {
        runs.push_back(run);
        run = 0;
      }
    }
  }
  if (runs.empty()) return 0;
  return percentile(runs, 0.5);
}

TEST(SyntheticScene, FingersAreThin) {
  const SceneConfig c = quiet(preset("hand", 1280, 720));
  const StereoSample s = render(c, 0);
  double thinnest = 1e9, widest = 0;
  int fingers = 0;
  for (const Object& o : c.objects) {
    if (o.shape != Shape::kCapsule) continue;
    ++fingers;
    const double d = c.focal_px * c.baseline_m / o.z_m;
    // A row crosses a tilted finger over diameter / |sin(angle)| pixels.
    const double expected = c.focal_px * o.height_m / o.z_m / std::abs(std::sin(o.angle_rad));
    const double run = median_run(s.disparity, static_cast<float>(d));
    EXPECT_NEAR(run, expected, 1.5) << "finger at " << o.z_m << " m";
    thinnest = std::min(thinnest, run);
    widest = std::max(widest, run);
  }
  EXPECT_EQ(fingers, 4);
  EXPECT_LE(thinnest, 8);
  EXPECT_GE(thinnest, 3);
  EXPECT_GE(widest, 20);
  EXPECT_LE(widest, 35);
}

TEST(SyntheticScene, ColorModeHasThreeChannelsAndSameGeometry) {
  SceneConfig c = quiet(preset("hand", 320, 180));
  const StereoSample grey = render(c, 8);
  c.color = true;
  const StereoSample color = render(c, 8);
  ASSERT_EQ(color.left.channels(), 3);
  ASSERT_EQ(color.right.channels(), 3);
  EXPECT_EQ(grey.left.channels(), 1);
  EXPECT_TRUE(same_bytes(grey.disparity, color.disparity));
  long differing = 0;
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) differing += color.left.at(x, y, 0) != color.left.at(x, y, 2);
  EXPECT_GT(differing, c.width * c.height / 4);  // really coloured, not grey copied thrice
}

TEST(SyntheticScene, TheRightCamerasRowsAreRenderedThatManyRowsLower) {
  SceneConfig c = preset("hand", 320, 180);
  c.noise_sigma = 0;  // the sensor's noise stays on the sensor's rows
  SceneConfig lower = c, half = c;
  lower.right_rows = 1;
  half.right_rows = 0.5;
  const StereoSample plain = render(c, 4), moved = render(lower, 4), between = render(half, 4);
  EXPECT_TRUE(same_bytes(plain.left, moved.left));
  EXPECT_TRUE(same_bytes(plain.disparity, moved.disparity));
  long differ_plain = 0, differ_moved = 0;
  for (int y = 1; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) {
      ASSERT_EQ(moved.right.at(x, y), plain.right.at(x, y - 1)) << x << "," << y;
      differ_plain += between.right.at(x, y) != plain.right.at(x, y);
      differ_moved += between.right.at(x, y) != moved.right.at(x, y);
    }
  // Half a row is rendered there, neither of the whole-row images.
  EXPECT_GT(differ_plain, c.width * c.height / 20);
  EXPECT_GT(differ_moved, c.width * c.height / 20);
}

TEST(SyntheticScene, TheRightCameraTurnedShowsItsSceneLowerTowardsTheRightEdge) {
  SceneConfig c = preset("boxes", 320, 180);
  c.noise_sigma = 0;
  SceneConfig turned = c;
  turned.right_roll_deg = 0.5;  // tan(0.5 deg) * 159.5 = 1.39 rows at the side edges
  const StereoSample plain = render(c, 2), other = render(turned, 2);
  EXPECT_TRUE(same_bytes(plain.left, other.left));
  EXPECT_TRUE(same_bytes(plain.disparity, other.disparity));
  // A column's scene lies lower by tan(roll) * (x - xc) rows: near the right edge the turned
  // view's 7x7 windows agree best with the upright view about 1.3 rows up, near the left edge
  // about 1.3 rows down, in the middle where they are.
  const auto best_row = [&](int x0) {
    double best = -1;
    int best_dy = 0;
    for (int dy = -3; dy <= 3; ++dy) {
      double sum = 0;
      for (int y = 40; y < 140; ++y)
        for (int x = x0 - 3; x <= x0 + 3; ++x)
          sum += std::abs(other.right.at(x, y) - plain.right.at(x, y - dy));
      if (best < 0 || sum < best) best = sum, best_dy = dy;
    }
    return best_dy;
  };
  EXPECT_EQ(best_row(10), -1);
  EXPECT_EQ(best_row(160), 0);
  EXPECT_EQ(best_row(309), 1);
}

TEST(SyntheticScene, BothLensesFallOffTowardsTheCorners) {
  SceneConfig c = preset("boxes", 320, 180);
  c.noise_sigma = 0;
  SceneConfig dark = c;
  dark.lens_falloff = 0.4;
  const StereoSample plain = render(c, 2), other = render(dark, 2);
  EXPECT_TRUE(same_bytes(plain.disparity, other.disparity));
  // Each view about its own centre (159.5, 89.5): V = 0.6 at a corner, 1 at the centre, and at
  // (80, 45), a quarter of the diagonal in, 1 - 0.4 / 4.
  for (const bool right : {false, true}) {
    const Image<std::uint8_t>& p = right ? plain.right : plain.left;
    const Image<std::uint8_t>& o = right ? other.right : other.left;
    EXPECT_NEAR(o.at(0, 0), 0.6 * p.at(0, 0), 0.51) << right;
    EXPECT_NEAR(o.at(319, 179), 0.6 * p.at(319, 179), 0.51) << right;
    EXPECT_NEAR(o.at(80, 45), 0.9 * p.at(80, 45), 0.6) << right;
    EXPECT_EQ(o.at(160, 90), p.at(160, 90)) << right;
  }
}

TEST(SyntheticScene, TheRightCamerasGainAndOffsetScaleOnlyItsLevels) {
  const SceneConfig c = preset("boxes", 320, 180);  // with its sensor noise
  SceneConfig scaled = c;
  scaled.right_gain = 1.2;
  scaled.right_offset = -7;
  const StereoSample plain = render(c, 3), other = render(scaled, 3);
  EXPECT_TRUE(same_bytes(plain.left, other.left));
  EXPECT_TRUE(same_bytes(plain.disparity, other.disparity));
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) {
      const double v = 1.2 * plain.right.at(x, y) - 7;
      ASSERT_EQ(other.right.at(x, y), std::clamp(std::lround(v), 0L, 255L)) << x << "," << y;
    }
}

TEST(SyntheticScene, PresetsRenderAtBothResolutions) {
  for (const char* name : {"hand", "boxes", "static"}) {
    const SceneConfig small = preset(name, 640, 360), big = preset(name, 1280, 720);
    EXPECT_DOUBLE_EQ(big.focal_px, 700);
    EXPECT_DOUBLE_EQ(small.focal_px, 350);
    EXPECT_EQ(small.objects.size(), big.objects.size());
    const StereoSample a = render(small, 3), b = render(big, 3);
    EXPECT_EQ(a.left.width(), 640);
    EXPECT_EQ(a.left.height(), 360);
    EXPECT_EQ(b.left.width(), 1280);
    EXPECT_EQ(b.depth_m.height(), 720);
    // Same scene: the depth at the same relative spot agrees, disparity halves.
    for (const auto& [fx, fy] : {std::pair{0.1, 0.1}, std::pair{0.5, 0.5}, std::pair{0.9, 0.8}}) {
      const int xs = static_cast<int>(fx * 639), ys = static_cast<int>(fy * 359);
      const int xb = 2 * xs, yb = 2 * ys;
      if (std::abs(a.depth_m.at(xs, ys) - b.depth_m.at(xb, yb)) > 0.05f) continue;  // edge
      EXPECT_NEAR(a.disparity.at(xs, ys) * 2, b.disparity.at(xb, yb), 0.2) << name;
    }
  }
  EXPECT_TRUE(preset("static").objects.size() == preset("hand").objects.size());
  for (const Object& o : preset("static").objects) {
    EXPECT_EQ(o.amp_x_m, 0);
    EXPECT_EQ(o.amp_y_m, 0);
    EXPECT_EQ(o.amp_z_m, 0);
  }
}

void expect_error(const SceneConfig& c, const std::string& needle) {
  try {
    SceneRenderer r(c);
    ADD_FAILURE() << "no error for " << needle;
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(needle), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

TEST(SyntheticScene, InvalidConfigsThrowNamingTheProblem) {
  const SceneConfig ok = preset("hand", 320, 180);
  EXPECT_NO_THROW(SceneRenderer{ok});
  auto with = [&](auto edit) {
    SceneConfig c = ok;
    edit(c);
    return c;
  };
  expect_error(with([](SceneConfig& c) { c.width = 8; }), "resolution");
  expect_error(with([](SceneConfig& c) { c.height = 9000; }), "resolution");
  expect_error(with([](SceneConfig& c) { c.focal_px = 0; }), "focal_px");
  expect_error(with([](SceneConfig& c) { c.baseline_m = -0.1; }), "baseline_m");
  expect_error(with([](SceneConfig& c) { c.fps = 0; }), "fps");
  expect_error(with([](SceneConfig& c) { c.noise_sigma = -1; }), "noise_sigma");
  expect_error(with([](SceneConfig& c) { c.noise_sigma = NAN; }), "noise_sigma");
  expect_error(with([](SceneConfig& c) { c.right_gain = 0.1; }), "right_gain");
  expect_error(with([](SceneConfig& c) { c.right_gain = NAN; }), "right_gain");
  expect_error(with([](SceneConfig& c) { c.right_offset = 200; }), "right_offset");
  expect_error(with([](SceneConfig& c) { c.right_rows = 9; }), "right_rows");
  {
    // A background whose disparity reaches 0 four rows above the image: the left view stays
    // clear of it, but a right view 8 rows off renders those rows.
    SceneConfig c = ok;
    c.objects.clear();
    c.background_slope_x = 0;
    c.background_slope_y =
        c.focal_px * c.baseline_m / c.background_z_m / ((c.height - 1) / 2.0 + 4);
    EXPECT_NO_THROW(SceneRenderer{c});
    c.right_rows = 8;
    expect_error(c, "background disparity");
  }
  expect_error(with([](SceneConfig& c) { c.right_roll_deg = -1.5; }), "right_roll_deg");
  expect_error(with([](SceneConfig& c) { c.right_roll_deg = NAN; }), "right_roll_deg");
  expect_error(with([](SceneConfig& c) { c.lens_falloff = 0.8; }), "lens_falloff");
  expect_error(with([](SceneConfig& c) { c.lens_falloff = -0.1; }), "lens_falloff");
  expect_error(with([](SceneConfig& c) { c.background_z_m = 0.05; }), "background_z_m");
  expect_error(with([](SceneConfig& c) { c.background_slope_y = 0.5; }), "background disparity");
  expect_error(with([](SceneConfig& c) { c.background_slope_x = 1; }), "background_slope_x");
  expect_error(with([](SceneConfig& c) { c.objects[1].z_m = 0.05; }), "object 1");
  expect_error(with([](SceneConfig& c) { c.objects[2].amp_z_m = 0.45; }), "object 2");
  expect_error(with([](SceneConfig& c) { c.objects[0].z_m = 3.5; }), "background");
  expect_error(with([](SceneConfig& c) { c.objects[3].width_m = 0; }), "object 3: size");
  expect_error(with([](SceneConfig& c) { c.objects[0].period_s = 0; }), "period_s");
  expect_error(with([](SceneConfig& c) { c.objects[0].texture_scale_m = 0; }), "texture_scale_m");
  expect_error(with([](SceneConfig& c) { c.objects[2].texture_scale_m = 1e-12; }), "too fine");
  expect_error(with([](SceneConfig& c) { c.objects[4].x_m = INFINITY; }), "object 4");
}

TEST(SyntheticScene, UnknownPresetListsTheKnownOnes) {
  try {
    preset("hands");
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string what = e.what();
    for (const char* needle : {"'hands'", "hand", "boxes", "static"})
      EXPECT_NE(what.find(needle), std::string::npos) << what;
  }
}

TEST(SyntheticScene, CalibrationIsTheIdealRectifiedRig) {
  const SceneConfig c = preset("boxes", 640, 360);
  const StereoCalibration calib = SceneRenderer(c).calibration();
  EXPECT_NO_THROW(calib.validate());
  EXPECT_TRUE(calib.is_rectified);
  EXPECT_EQ(calib.rectified.width, 640);
  EXPECT_EQ(calib.rectified.height, 360);
  EXPECT_DOUBLE_EQ(calib.rectified.f, c.focal_px);
  EXPECT_DOUBLE_EQ(calib.rectified.baseline_m, c.baseline_m);
  EXPECT_DOUBLE_EQ(calib.rectified.cx_left, 319.5);
  EXPECT_DOUBLE_EQ(calib.rectified.cx_right, 319.5);
  EXPECT_DOUBLE_EQ(calib.rectified.cy, 179.5);
  for (const CameraIntrinsics* cam : {&calib.left, &calib.right}) {
    EXPECT_EQ(cam->model, CameraModel::kPinhole);
    EXPECT_TRUE(cam->distortion.empty());
    EXPECT_DOUBLE_EQ(cam->fx, c.focal_px);
    EXPECT_DOUBLE_EQ(cam->fy, c.focal_px);
    EXPECT_DOUBLE_EQ(cam->cx, 319.5);
    EXPECT_DOUBLE_EQ(cam->cy, 179.5);
    EXPECT_EQ(cam->width, 640);
  }
  EXPECT_EQ(calib.rotation, (std::array<double, 9>{1, 0, 0, 0, 1, 0, 0, 0, 1}));
  EXPECT_EQ(calib.translation, (std::array<double, 3>{-c.baseline_m, 0, 0}));
  // The ground truth follows the calibration's own disparity/depth relation.
  const StereoSample s = render(c, 0);
  EXPECT_NEAR(calib.rectified.depth_from_disparity(s.disparity.at(100, 100)),
              s.depth_m.at(100, 100), 1e-5);
}

TEST(SyntheticScene, RenderingAgainReusesTheBuffers) {
  const SceneRenderer r(preset("hand", 640, 360));
  StereoSample s;
  r.render(0, s);
  const void* p[] = {s.left.data(), s.right.data(), s.disparity.data(), s.depth_m.data()};
  r.render(0, s);
  r.render(7, s);
  const void* q[] = {s.left.data(), s.right.data(), s.disparity.data(), s.depth_m.data()};
  for (int i = 0; i < 4; ++i) EXPECT_EQ(p[i], q[i]) << "buffer " << i;
  // Resizing explicitly confirms no further allocation would be needed.
  EXPECT_FALSE(s.left.resize(640, 360, 1));
  EXPECT_FALSE(s.disparity.resize(640, 360));
}

}  // namespace
}  // namespace dco::synthetic
