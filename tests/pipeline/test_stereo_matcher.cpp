#include "dco/pipeline/stereo/stereo_matcher.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <new>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "dco/core/image.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/pipeline/stereo/image_ops.hpp"
#include "support/allocation_counter.hpp"
#include "support/same_bytes.hpp"

namespace dco::stereo {
namespace {

using dco::testing::same_bytes;

using ::testing::HasSubstr;

constexpr int kBackground = 8;   // disparity of the background plane, input pixels
constexpr int kForeground = 20;  // disparity of the foreground rectangle

std::uint8_t texture(int u, int y, int layer, int c) {
  std::uint32_t h = static_cast<std::uint32_t>(u) * 0x9e3779b1u ^
                    static_cast<std::uint32_t>(y) * 0x85ebca77u ^
                    static_cast<std::uint32_t>(layer * 3 + c + 1) * 0xc2b2ae3du;
  h ^= h >> 15;
  h *= 0x2c1b3c6du;
  h ^= h >> 12;
  h *= 0x297a2d39u;
  h ^= h >> 15;
  return static_cast<std::uint8_t>(h & 0xff);
}

// A rectified pair of a textured fronto-parallel background at kBackground and a textured
// rectangle [x0, x1) x [y0, y1) (left-image coordinates) at kForeground, built by shifting:
// left(x) shows the surface whose right-image position is x - d.
struct Scene {
  Image<std::uint8_t> left, right;
  Image<float> truth;           // left-view disparity
  Image<std::uint8_t> visible;  // the left pixel is seen in the right image
};

Scene make_scene(int w, int h, int channels, int x0, int x1, int y0, int y1) {
  Scene s;
  s.left = Image<std::uint8_t>(w, h, channels);
  s.right = Image<std::uint8_t>(w, h, channels);
  s.truth = Image<float>(w, h);
  s.visible = Image<std::uint8_t>(w, h);
  const auto in_rect = [&](int x, int y) { return x >= x0 && x < x1 && y >= y0 && y < y1; };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool fg = in_rect(x, y);
      const int d = fg ? kForeground : kBackground;
      for (int c = 0; c < channels; ++c) {
        s.left.at(x, y, c) = texture(x - d, y, fg ? 1 : 0, c);
        // Right pixel x shows the rectangle where the left rectangle lands after the shift.
        const bool fg_right = in_rect(x + kForeground, y);
        s.right.at(x, y, c) = texture(x, y, fg_right ? 1 : 0, c);
      }
      s.truth.at(x, y) = static_cast<float>(d);
      const int xr = x - d;
      s.visible.at(x, y) = xr >= 0 && (fg || !in_rect(xr + kForeground, y));
    }
  return s;
}

struct Score {
  double density = 0;   // finite pixels / all pixels
  double accurate = 0;  // finite pixels within 1 px of the truth / finite pixels
  double max_value = 0;
  long bad_values = 0;  // NaN, -inf, or finite <= 0
};

Score score(const Image<float>& disp, const Scene& s) {
  Score r;
  long finite = 0, good = 0;
  for (int y = 0; y < disp.height(); ++y)
    for (int x = 0; x < disp.width(); ++x) {
      const float v = disp.at(x, y);
      if (std::isnan(v) || (std::isinf(v) && v < 0) || (std::isfinite(v) && v <= 0.0f)) {
        ++r.bad_values;
        continue;
      }
      if (!std::isfinite(v)) continue;
      ++finite;
      good += std::abs(v - s.truth.at(x, y)) <= 1.0f;
      r.max_value = std::max<double>(r.max_value, v);
    }
  const double n = double(disp.width()) * disp.height();
  r.density = finite / n;
  r.accurate = finite ? double(good) / finite : 0.0;
  return r;
}

Scene small_scene(int channels) {
  return make_scene(320, 120, channels, 120, 220, 30, 90);
}
Scene hd_scene(int channels) {
  return make_scene(1280, 720, channels, 480, 880, 200, 520);
}

void expect_accurate(const Scene& s, int expected_scale) {
  StereoParams params;
  ASSERT_EQ(internal_scale(params, s.left.width()), expected_scale);
  const auto matcher = make_cpu_stereo_matcher(params);
  Image<float> disp;
  matcher->compute(s.left.cview(), s.right.cview(), disp);
  ASSERT_EQ(disp.width(), s.left.width());
  ASSERT_EQ(disp.height(), s.left.height());
  const Score r = score(disp, s);
  EXPECT_EQ(r.bad_values, 0);
  EXPECT_GT(r.accurate, 0.95);
  EXPECT_GT(r.density, 0.8);
  EXPECT_LE(r.max_value, params.max_disparity);
  // Both surfaces are found.
  long fg = 0, bg = 0;
  for (int y = 0; y < disp.height(); ++y)
    for (int x = 0; x < disp.width(); ++x) {
      const float v = disp.at(x, y);
      fg += std::abs(v - kForeground) <= 1.0f;
      bg += std::abs(v - kBackground) <= 1.0f;
    }
  EXPECT_GT(fg, 0.1 * disp.width() * disp.height());
  EXPECT_GT(bg, 0.3 * disp.width() * disp.height());
  // Pixels that the right camera cannot see have no trustworthy match; most must be unknown.
  long hidden = 0, hidden_known = 0;
  for (int y = 0; y < disp.height(); ++y)
    for (int x = 0; x < disp.width(); ++x)
      if (!s.visible.at(x, y)) {
        ++hidden;
        hidden_known += std::isfinite(disp.at(x, y));
      }
  EXPECT_LT(hidden_known, 0.2 * hidden);
}

TEST(CpuStereoMatcher, GrayPairAtFullInternalResolution) {
  expect_accurate(small_scene(1), 1);
}

TEST(CpuStereoMatcher, BgrPairAtFullInternalResolution) {
  expect_accurate(small_scene(3), 1);
}

TEST(CpuStereoMatcher, GrayPairAtHalfInternalResolutionReportsInputPixels) {
  expect_accurate(hd_scene(1), 2);
}

TEST(CpuStereoMatcher, BgrPairAtHalfInternalResolutionReportsInputPixels) {
  expect_accurate(hd_scene(3), 2);
}

TEST(CpuStereoMatcher, HalfResolutionOutputIsExpandedFromTwoByTwoBlocks) {
  const Scene s = make_scene(646, 362, 1, 201, 421, 101, 261);  // odd internal width 323
  StereoParams blocks;
  blocks.boundary_radius = 0;  // no boundary refinement
  Image<float> disp;
  make_cpu_stereo_matcher(blocks)->compute(s.left.cview(), s.right.cview(), disp);
  ASSERT_EQ(disp.width(), 646);
  ASSERT_EQ(disp.height(), 362);
  for (int y = 0; y < 362; y += 2)
    for (int x = 0; x < 646; x += 2) {
      const float v = disp.at(x, y);
      ASSERT_TRUE(std::memcmp(&v, &disp.at(x + 1, y), sizeof v) == 0 &&
                  std::memcmp(&v, &disp.at(x, y + 1), sizeof v) == 0 &&
                  std::memcmp(&v, &disp.at(x + 1, y + 1), sizeof v) == 0)
          << x << "," << y;
    }
  const Score plain = score(disp, s);
  EXPECT_GT(plain.accurate, 0.95);

  // With the boundary refinement (the default) only pixels near the rectangle's outline (and in
  // the left border, whose background has no match in the right image) change: the outline sits
  // on odd input pixels, inside 2x2 blocks. This texture is the same noise on both surfaces, so
  // grey levels cannot tell the support windows' surfaces apart: the refinement mostly abstains
  // and must not make the map less accurate (tests/pipeline/test_boundary_refinement.cpp has
  // the surfaces it can tell apart).
  Image<float> refined;
  make_cpu_stereo_matcher(StereoParams{})->compute(s.left.cview(), s.right.cview(), refined);
  long changed = 0;
  for (int y = 0; y < 362; ++y)
    for (int x = 0; x < 646; ++x) {
      if (std::memcmp(&disp.at(x, y), &refined.at(x, y), sizeof(float)) == 0) continue;
      ++changed;
      const bool near_outline = x < 2 * kBackground || std::abs(x - 201) <= 8 ||
                                std::abs(x - 421) <= 8 || std::abs(y - 101) <= 8 ||
                                std::abs(y - 261) <= 8;
      EXPECT_TRUE(near_outline) << x << "," << y;
    }
  EXPECT_GT(changed, 100);
  EXPECT_GE(score(refined, s).accurate, plain.accurate);
}

TEST(CpuStereoMatcher, OddInputSizeAtHalfResolutionFillsTheLastColumnAndRow) {
  const Scene s = make_scene(645, 363, 1, 200, 420, 100, 260);
  const auto matcher = make_cpu_stereo_matcher(StereoParams{});
  Image<float> disp;
  matcher->compute(s.left.cview(), s.right.cview(), disp);
  ASSERT_EQ(disp.width(), 645);
  ASSERT_EQ(disp.height(), 363);
  const Score r = score(disp, s);
  EXPECT_EQ(r.bad_values, 0);
  EXPECT_GT(r.accurate, 0.95);
  // The last column and row repeat their neighbours.
  for (int y = 0; y < 363; ++y)
    ASSERT_EQ(std::memcmp(&disp.at(644, y), &disp.at(643, y), sizeof(float)), 0) << y;
  for (int x = 0; x < 645; ++x)
    ASSERT_EQ(std::memcmp(&disp.at(x, 362), &disp.at(x, 361), sizeof(float)), 0) << x;
}

TEST(CpuStereoMatcher, UnknownPixelsAreInfinityAndNoValueIsNonPositive) {
  // Left border and occlusions are always unknown.
  const Scene s = small_scene(1);
  const auto matcher = make_cpu_stereo_matcher(StereoParams{});
  Image<float> disp;
  matcher->compute(s.left.cview(), s.right.cview(), disp);
  long unknown = 0;
  for (int y = 0; y < disp.height(); ++y)
    for (int x = 0; x < disp.width(); ++x) {
      const float v = disp.at(x, y);
      ASSERT_FALSE(std::isnan(v)) << x << "," << y;
      if (std::isfinite(v)) {
        ASSERT_GT(v, 0.0f) << x << "," << y;
      } else {
        ASSERT_EQ(v, std::numeric_limits<float>::infinity()) << x << "," << y;
        ++unknown;
      }
    }
  EXPECT_GT(unknown, 0);

  // A featureless pair has nothing to match at all.
  Image<std::uint8_t> flat(96, 40);
  flat.fill(128);
  matcher->compute(flat.cview(), flat.cview(), disp);
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 96; ++x) {
      const float v = disp.at(x, y);
      ASSERT_TRUE(std::isinf(v) || v > 0.0f) << x << "," << y;
    }
}

TEST(CpuStereoMatcher, MaxDisparityIsRespected) {
  for (bool hd : {false, true}) {
    const Scene s = hd ? hd_scene(1) : small_scene(1);
    for (int max_d : {12, 16}) {
      StereoParams params;
      params.max_disparity = max_d;
      const auto matcher = make_cpu_stereo_matcher(params);
      Image<float> disp;
      matcher->compute(s.left.cview(), s.right.cview(), disp);
      const Score r = score(disp, s);
      EXPECT_EQ(r.bad_values, 0);
      EXPECT_LE(r.max_value, max_d) << (hd ? "1280x720" : "320x120");
      // The background is still found.
      long bg = 0;
      for (int y = 0; y < disp.height(); ++y)
        for (int x = 0; x < disp.width(); ++x) bg += std::abs(disp.at(x, y) - kBackground) <= 1;
      EXPECT_GT(bg, 0.3 * disp.width() * disp.height());
    }
  }
}

TEST(CpuStereoMatcher, OddMaxDisparityAtHalfResolutionStaysWithinIt) {
  // A background at disparity 16, which an odd limit of 15 excludes.
  Scene s = hd_scene(1);
  for (int y = 0; y < 720; ++y)
    for (int x = 0; x < 1280; ++x) {
      s.left.at(x, y) = texture(x - 16, y, 0, 0);
      s.right.at(x, y) = texture(x, y, 0, 0);
    }
  StereoParams params;
  params.max_disparity = 15;
  const auto matcher = make_cpu_stereo_matcher(params);
  Image<float> disp;
  matcher->compute(s.left.cview(), s.right.cview(), disp);
  float max_value = 0;
  for (int y = 0; y < 720; ++y)
    for (int x = 0; x < 1280; ++x)
      if (std::isfinite(disp.at(x, y))) max_value = std::max(max_value, disp.at(x, y));
  EXPECT_LE(max_value, 15.0f);
}

std::string compute_error(StereoMatcher& m, ImageView<const std::uint8_t> l,
                          ImageView<const std::uint8_t> r) {
  Image<float> disp;
  try {
    m.compute(l, r, disp);
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(CpuStereoMatcher, BadInputThrowsErrorsThatNameTheProblem) {
  const auto matcher = make_cpu_stereo_matcher(StereoParams{});
  const Scene s = small_scene(1);
  const Scene c = small_scene(3);
  Image<std::uint8_t> empty;
  EXPECT_THAT(compute_error(*matcher, empty.cview(), s.right.cview()), HasSubstr("empty"));
  EXPECT_THAT(compute_error(*matcher, s.left.cview(), empty.cview()), HasSubstr("empty"));

  Image<std::uint8_t> taller(320, 121);
  taller.fill(0);
  const std::string size_error = compute_error(*matcher, s.left.cview(), taller.cview());
  EXPECT_THAT(size_error, HasSubstr("320x120x1"));
  EXPECT_THAT(size_error, HasSubstr("320x121x1"));

  const std::string channel_error = compute_error(*matcher, s.left.cview(), c.right.cview());
  EXPECT_THAT(channel_error, HasSubstr("320x120x1"));
  EXPECT_THAT(channel_error, HasSubstr("320x120x3"));

  Image<std::uint8_t> two(320, 120, 2);
  two.fill(0);
  EXPECT_THAT(compute_error(*matcher, two.cview(), two.cview()), HasSubstr("1 or 3 channels"));

  Image<std::uint8_t> tiny(8, 6);
  tiny.fill(0);
  EXPECT_THAT(compute_error(*matcher, tiny.cview(), tiny.cview()), HasSubstr("census window"));

  for (int max_d : {320, 400}) {
    StereoParams params;
    params.max_disparity = max_d;
    const auto wide = make_cpu_stereo_matcher(params);
    const std::string e = compute_error(*wide, s.left.cview(), s.right.cview());
    EXPECT_THAT(e, HasSubstr("max disparity " + std::to_string(max_d)));
    EXPECT_THAT(e, HasSubstr("width 320"));
  }
  // Above 640 px the limits hold at half size, and the errors name that size.
  Image<std::uint8_t> flat(645, 7);
  flat.fill(0);
  const std::string flat_error = compute_error(*matcher, flat.cview(), flat.cview());
  EXPECT_THAT(flat_error, HasSubstr("645x7, matched at half size (322x3)"));
  EXPECT_THAT(flat_error, HasSubstr("9x7 census window"));
  Image<std::uint8_t> wide_image(641, 40);
  wide_image.fill(0);
  StereoParams wide_max;
  wide_max.max_disparity = 640;
  const std::string half_error =
      compute_error(*make_cpu_stereo_matcher(wide_max), wide_image.cview(), wide_image.cview());
  EXPECT_THAT(half_error, HasSubstr("max disparity 640 (320 px at half size)"));
  EXPECT_THAT(half_error, HasSubstr("half-size width 320 (image 641x40)"));
  StereoParams one;
  one.max_disparity = 1;  // 0 at half size: nothing would be searched
  EXPECT_THAT(compute_error(*make_cpu_stereo_matcher(one), wide_image.cview(), wide_image.cview()),
              HasSubstr("max disparity 1 is no whole pixel at half size"));

  StereoParams just_fits;
  just_fits.max_disparity = 319;
  EXPECT_EQ(compute_error(*make_cpu_stereo_matcher(just_fits), s.left.cview(), s.right.cview()),
            "no error");

  // A failed call leaves the matcher usable.
  Image<float> disp;
  EXPECT_NO_THROW(matcher->compute(s.left.cview(), s.right.cview(), disp));
  EXPECT_GT(score(disp, s).accurate, 0.95);
}

TEST(CpuStereoMatcher, AcceptsStridedViews) {
  const Scene s = small_scene(3);
  Image<std::uint8_t> big_l(340, 130, 3), big_r(340, 130, 3);
  big_l.fill(0);
  big_r.fill(255);
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 320; ++x)
      for (int c = 0; c < 3; ++c) {
        big_l.at(x + 7, y + 4, c) = s.left.at(x, y, c);
        big_r.at(x + 11, y + 2, c) = s.right.at(x, y, c);
      }
  const auto matcher = make_cpu_stereo_matcher(StereoParams{});
  Image<float> from_views, direct;
  matcher->compute(big_l.cview().sub(7, 4, 320, 120), big_r.cview().sub(11, 2, 320, 120),
                   from_views);
  matcher->compute(s.left.cview(), s.right.cview(), direct);
  EXPECT_TRUE(same_bytes(from_views, direct));
}

TEST(CpuStereoMatcher, BgrWithoutColourEqualsItsGreyImage) {
  // use_color = false: the BGR pair is matched on its grey conversion only.
  const Scene s = small_scene(3);
  Image<std::uint8_t> gl(s.left.width(), s.left.height()), gr(gl.width(), gl.height());
  bgr_to_gray(s.left.cview(), gl.view());
  bgr_to_gray(s.right.cview(), gr.view());
  StereoParams params;
  params.use_color = false;
  const auto matcher = make_cpu_stereo_matcher(params);
  Image<float> from_bgr, from_gray;
  matcher->compute(s.left.cview(), s.right.cview(), from_bgr);
  matcher->reset();  // not the next frame of a sequence: the same frame again
  matcher->compute(gl.cview(), gr.cview(), from_gray);
  EXPECT_TRUE(same_bytes(from_bgr, from_gray));
  // With colour the result differs (the AD term and the arms see three channels).
  params.use_color = true;
  Image<float> colour;
  make_cpu_stereo_matcher(params)->compute(s.left.cview(), s.right.cview(), colour);
  EXPECT_FALSE(same_bytes(from_bgr, colour));
}

TEST(CpuStereoMatcher, HalfResolutionIsFullResolutionOnTheHalvedPair) {
  // The half-size path must equal matching the 2x2-averaged pair at full internal resolution
  // with lengths halved, reported doubled and expanded to the input size.
  for (int channels : {1, 3}) {
    const Scene s = hd_scene(channels);
    Image<std::uint8_t> sl(640, 360, channels), sr(640, 360, channels);
    downsample_half(s.left.cview(), sl.view());
    downsample_half(s.right.cview(), sr.view());
    StereoParams half;         // auto: 1280 px wide -> half
    half.boundary_radius = 0;  // the refinement at input resolution has tests of its own
    StereoParams full;
    full.internal_resolution = "full";
    full.max_disparity = half.max_disparity / 2;
    full.arm_max = half.arm_max / 2;
    full.arm_short = half.arm_short / 2;
    Image<float> big, small;
    make_cpu_stereo_matcher(half)->compute(s.left.cview(), s.right.cview(), big);
    make_cpu_stereo_matcher(full)->compute(sl.cview(), sr.cview(), small);
    ASSERT_EQ(small.width(), 640);
    long mismatches = 0;
    for (int y = 0; y < 720; ++y)
      for (int x = 0; x < 1280; ++x) {
        const float expected = 2.0f * small.at(x / 2, y / 2);
        mismatches += std::memcmp(&expected, &big.at(x, y), sizeof(float)) != 0;
      }
    EXPECT_EQ(mismatches, 0) << channels << " channels";
  }
}

TEST(CpuStereoMatcher, WithoutSubpixelValuesAreWholeInternalPixels) {
  for (bool hd : {false, true}) {
    const Scene s = hd ? hd_scene(1) : small_scene(1);
    StereoParams params;
    params.subpixel = false;
    const auto matcher = make_cpu_stereo_matcher(params);
    Image<float> disp;
    matcher->compute(s.left.cview(), s.right.cview(), disp);
    const float step = hd ? 2.0f : 1.0f;
    long finite = 0, exact = 0;
    for (int y = 0; y < disp.height(); ++y)
      for (int x = 0; x < disp.width(); ++x) {
        const float v = disp.at(x, y);
        if (!std::isfinite(v)) continue;
        ++finite;
        ASSERT_EQ(v / step, std::floor(v / step)) << x << "," << y << " value " << v;
        exact += v == s.truth.at(x, y);
      }
    // Integer shifts: the whole-pixel answer is the exact truth almost everywhere.
    EXPECT_GT(exact, 0.95 * finite);
  }
}

TEST(CpuStereoMatcher, DiscontinuityCheckOnlyRemovesPixels) {
  const Scene s = small_scene(1);
  StereoParams on, off;
  off.max_neighbour_jump = -1;
  Image<float> with, without;
  make_cpu_stereo_matcher(on)->compute(s.left.cview(), s.right.cview(), with);
  make_cpu_stereo_matcher(off)->compute(s.left.cview(), s.right.cview(), without);
  long removed = 0;
  for (int y = 0; y < with.height(); ++y)
    for (int x = 0; x < with.width(); ++x) {
      if (std::isfinite(with.at(x, y))) {
        ASSERT_EQ(std::memcmp(&with.at(x, y), &without.at(x, y), sizeof(float)), 0)
            << x << "," << y;
      } else if (std::isfinite(without.at(x, y))) {
        ++removed;
      }
    }
  // The rectangle's left and right edges are depth jumps of 12 px: pixels there go.
  EXPECT_GT(removed, 2 * 60);
}

// Sizes of the 4-connected islands of known pixels in an internal-resolution sparse map.
std::vector<int> island_sizes(ImageView<const float> map) {
  const int w = map.width, h = map.height;
  std::vector<char> seen(static_cast<std::size_t>(w) * h, 0);
  std::vector<int> sizes, stack;
  for (int start = 0; start < w * h; ++start) {
    if (seen[start] || !std::isfinite(map.row(start / w)[start % w])) continue;
    int size = 0;
    stack.push_back(start);
    seen[start] = 1;
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      ++size;
      const int x = i % w, y = i / w;
      const int next[4][2] = {{x - 1, y}, {x + 1, y}, {x, y - 1}, {x, y + 1}};
      for (const auto& n : next) {
        if (n[0] < 0 || n[0] >= w || n[1] < 0 || n[1] >= h) continue;
        const int j = n[1] * w + n[0];
        if (!seen[j] && std::isfinite(map.row(n[1])[n[0]])) {
          seen[j] = 1;
          stack.push_back(j);
        }
      }
    }
    sizes.push_back(size);
  }
  return sizes;
}

TEST(CpuStereoMatcher, SpeckleFilterOnlyRemovesSmallIslands) {
  // A noisy textured pair: some wrong matches survive the checks as tiny islands.
  const synthetic::SceneRenderer scene(synthetic::preset("hand", 320, 180));
  synthetic::StereoSample s;
  scene.render(0, s);
  StereoParams with_filter, without;
  with_filter.max_disparity = without.max_disparity =
      synthetic::covering_max_disparity(scene.config());
  without.speckle_size = 0;
  with_filter.speckle_size = 4;
  const auto a = make_cpu_stereo_matcher(with_filter);
  const auto b = make_cpu_stereo_matcher(without);
  Image<float> da, db;
  a->compute(s.left.cview(), s.right.cview(), da);
  b->compute(s.left.cview(), s.right.cview(), db);
  const auto small = [](const std::vector<int>& sizes) {
    return std::count_if(sizes.begin(), sizes.end(), [](int n) { return n < 4; });
  };
  EXPECT_GT(small(island_sizes(b->internal_sparse_disparity())), 0)
      << "the scene has islands for the filter to remove";
  EXPECT_EQ(small(island_sizes(a->internal_sparse_disparity())), 0);
  long removed = 0;
  for (int y = 0; y < da.height(); ++y)
    for (int x = 0; x < da.width(); ++x) {
      if (std::isfinite(da.at(x, y)))
        ASSERT_EQ(std::memcmp(&da.at(x, y), &db.at(x, y), sizeof(float)), 0) << x << "," << y;
      else
        removed += std::isfinite(db.at(x, y));
    }
  EXPECT_GT(removed, 0);
}

TEST(CpuStereoMatcher, RepeatedComputeIsBitIdentical) {
  for (bool hd : {false, true}) {
    const Scene s = hd ? hd_scene(3) : small_scene(3);
    const Scene other = small_scene(1);
    const auto matcher = make_cpu_stereo_matcher(StereoParams{});
    Image<float> first, second, third, fresh, scratch;
    matcher->compute(s.left.cview(), s.right.cview(), first);
    matcher->compute(s.left.cview(), s.right.cview(), second);
    EXPECT_TRUE(same_bytes(first, second));
    // Another geometry in between leaves no trace.
    matcher->compute(other.left.cview(), other.right.cview(), scratch);
    matcher->compute(s.left.cview(), s.right.cview(), third);
    EXPECT_TRUE(same_bytes(first, third));
    // A new matcher agrees.
    make_cpu_stereo_matcher(StereoParams{})->compute(s.left.cview(), s.right.cview(), fresh);
    EXPECT_TRUE(same_bytes(first, fresh));
  }
}

// A wide search (13 batches of 16 at full size, 7 at half) guided by the half-size pass finds
// what the full search finds, while searching at most half of the (row, batch) pairs: the scene
// has two disparities.
TEST(CpuStereoMatcher, GuidedSearchFindsWhatTheFullSearchFinds) {
  for (const bool hd : {false, true}) {
    const Scene s = hd ? hd_scene(3) : small_scene(3);
    StereoParams params;
    params.max_disparity = 200;
    params.search_range = "full";
    const auto full = make_cpu_stereo_matcher(params);
    params.search_range = "guided";
    const auto guided = make_cpu_stereo_matcher(params);
    Image<float> a, b;
    full->compute(s.left.cview(), s.right.cview(), a);
    guided->compute(s.left.cview(), s.right.cview(), b);
    EXPECT_EQ(full->last_timings().searched_fraction, 1.0);
    EXPECT_GT(guided->last_timings().searched_fraction, 0.0);
    EXPECT_LT(guided->last_timings().searched_fraction, 0.5);
    long same = 0;
    for (int y = 0; y < a.height(); ++y)
      for (int x = 0; x < a.width(); ++x)
        same += std::memcmp(&a.at(x, y), &b.at(x, y), sizeof(float)) == 0;
    EXPECT_GT(same, 0.99 * a.width() * a.height()) << (hd ? "half size" : "full size");
    const Score r = score(b, s);
    EXPECT_EQ(r.bad_values, 0);
    EXPECT_GT(r.accurate, 0.95);
  }
}

// Share of the pixels in front of the background (the truth at least 3 px above the empty
// scene's) whose value is within 1 px of the truth.
double found_in_front(const Image<float>& d, const synthetic::StereoSample& with,
                      const synthetic::StereoSample& without) {
  long in_front = 0, found = 0;
  for (int y = 0; y < d.height(); ++y)
    for (int x = 0; x < d.width(); ++x) {
      const float truth = with.disparity.at(x, y);
      if (truth < without.disparity.at(x, y) + 3) continue;
      ++in_front;
      found += std::isfinite(d.at(x, y)) && std::fabs(d.at(x, y) - truth) <= 1.0f;
    }
  return static_cast<double>(found) / static_cast<double>(std::max(1L, in_front));
}

// "temporal" guides a frame by the previous frame's map and a quarter-size pass: a sequence's
// first frame, a frame after reset() or after another geometry takes the half-size pass
// ("guided") instead, and a hand that comes into view in front of an empty scene is found in
// its first frame as the half-size pass finds it.
TEST(CpuStereoMatcher, TemporalSearchFindsWhatComesIntoView) {
  const synthetic::SceneConfig with = synthetic::preset("hand", 640, 360);
  synthetic::SceneConfig without = with;
  without.objects.clear();
  const synthetic::SceneRenderer hand(with), empty(without);
  StereoParams params;
  params.max_disparity = synthetic::covering_max_disparity(with);
  params.search_range = "temporal";
  const auto temporal = make_cpu_stereo_matcher(params);
  params.search_range = "guided";
  const auto guided = make_cpu_stereo_matcher(params);
  synthetic::StereoSample a, b;
  Image<float> t, g;
  empty.render(8, a);
  temporal->compute(a.left.cview(), a.right.cview(), t);
  guided->compute(a.left.cview(), a.right.cview(), g);
  EXPECT_TRUE(same_bytes(t, g)) << "a first frame";
  empty.render(9, a);
  temporal->compute(a.left.cview(), a.right.cview(), t);
  EXPECT_LT(temporal->last_timings().searched_fraction, 1.0);
  for (int frame = 10; frame < 13; ++frame) {
    hand.render(frame, b);
    empty.render(frame, a);
    temporal->compute(b.left.cview(), b.right.cview(), t);
    guided->reset();
    guided->compute(b.left.cview(), b.right.cview(), g);
    EXPECT_FALSE(same_bytes(t, g)) << "frame " << frame << " took the half-size pass";
    const double found = found_in_front(t, b, a), by_guided = found_in_front(g, b, a);
    EXPECT_GT(by_guided, 0.85) << frame;
    EXPECT_GT(found, by_guided - (frame == 10 ? 0.02 : 0.01)) << frame;
  }
  temporal->reset();
  hand.render(13, b);
  temporal->compute(b.left.cview(), b.right.cview(), t);
  guided->reset();
  guided->compute(b.left.cview(), b.right.cview(), g);
  EXPECT_TRUE(same_bytes(t, g)) << "after a reset";
  // A frame of another size in between: the next one has no previous map of its size.
  const Scene other = small_scene(1);
  temporal->compute(other.left.cview(), other.right.cview(), t);
  hand.render(14, b);
  temporal->compute(b.left.cview(), b.right.cview(), t);
  guided->reset();
  guided->compute(b.left.cview(), b.right.cview(), g);
  EXPECT_TRUE(same_bytes(t, g)) << "after another geometry";
}

// stereo.row_threads shares the stage's rows among threads (the input downscaled, grey and
// packed, the census, the search, whose half-size pass shares the same threads, and the boundary
// refinement): the same map, guided or full, grey or colour, at full and half size.
TEST(CpuStereoMatcher, RowThreadsGiveTheMapOfOneThread) {
  for (const auto& [hd, channels] : {std::pair{false, 3}, std::pair{true, 3}, std::pair{true, 1}}) {
    const Scene s = hd ? hd_scene(channels) : small_scene(channels);
    for (const char* range : {"guided", "full"}) {
      StereoParams params;
      params.max_disparity = 200;
      params.search_range = range;
      params.row_threads = 1;
      const auto one = make_cpu_stereo_matcher(params);
      params.row_threads = 3;
      const auto three = make_cpu_stereo_matcher(params);
      Image<float> a, b;
      one->compute(s.left.cview(), s.right.cview(), a);
      three->compute(s.left.cview(), s.right.cview(), b);
      EXPECT_TRUE(testing::same_bytes(a, b))
          << range << (hd ? ", half size, " : ", full size, ") << channels << " channels";
      EXPECT_TRUE(testing::same_bytes(one->internal_sparse_disparity(),
                                      three->internal_sparse_disparity()));
    }
  }
  EXPECT_EQ(StereoParams{}.row_threads, 0) << "auto";
}

// "auto" guides only searches of more than four batches; a guide too small to run searches all.
TEST(CpuStereoMatcher, AutoSearchRangeGuidesOnlyWideSearches) {
  const Scene s = small_scene(1);
  Image<float> out;
  for (const auto& [max_disparity, range, guided] : {std::tuple{63, "auto", false},
                                                     {64, "auto", true},
                                                     {200, "auto", true},
                                                     {200, "full", false},
                                                     {40, "guided", true}}) {
    StereoParams params;
    params.max_disparity = max_disparity;
    params.search_range = range;
    const auto matcher = make_cpu_stereo_matcher(params);
    matcher->compute(s.left.cview(), s.right.cview(), out);
    EXPECT_EQ(matcher->last_timings().searched_fraction < 1.0, guided)
        << max_disparity << " " << range;
  }
  // 24x12 halves to 12x6, smaller than the 9x7 census window: no guide.
  Image<std::uint8_t> tiny(24, 12);
  tiny.fill(100);
  StereoParams params;
  params.max_disparity = 20;
  params.search_range = "guided";
  const auto matcher = make_cpu_stereo_matcher(params);
  matcher->compute(tiny.cview(), tiny.cview(), out);
  EXPECT_EQ(matcher->last_timings().searched_fraction, 1.0);
}

// A sequence's first frame sizes the half-size pass's buffers, its second the temporal guide's
// (StereoParams::search_range); from then on nothing allocates, after a reset neither.
TEST(CpuStereoMatcher, WarmComputesOnTheSameGeometryDoNotAllocate) {
  for (int channels : {1, 3})
    for (bool hd : {false, true}) {
      const Scene s = hd ? hd_scene(channels) : small_scene(channels);
      // A search wide enough for the guide of "auto", whose passes must not allocate either.
      StereoParams params;
      params.max_disparity = 150;
      const auto matcher = make_cpu_stereo_matcher(params);
      Image<float> disp;
      // The first call sizes every buffer, which the counters must see.
      testing::start_counting_allocations();
      matcher->compute(s.left.cview(), s.right.cview(), disp);
      const testing::AllocationCounts first = testing::stop_counting_allocations();
      EXPECT_GT(first.new_calls, 0);
      if (testing::kCountsAlignedAlloc) {
        EXPECT_GT(first.aligned_alloc_calls, 0);
      }
      const float* const data = disp.data();
      matcher->compute(s.left.cview(), s.right.cview(), disp);
      EXPECT_LT(matcher->last_timings().searched_fraction, 1.0);

      for (const bool reset : {false, true}) {
        if (reset) matcher->reset();
        testing::start_counting_allocations();
        matcher->compute(s.left.cview(), s.right.cview(), disp);
        const testing::AllocationCounts warm = testing::stop_counting_allocations();
        EXPECT_EQ(warm.new_calls, 0) << channels << " channels, " << (hd ? "half" : "full")
                                     << (reset ? ", after a reset" : "");
        EXPECT_EQ(warm.aligned_alloc_calls, 0)
            << channels << " channels, " << (hd ? "half" : "full");
        EXPECT_EQ(disp.data(), data);
      }
    }
}

TEST(AllocationCounter, SeesAllocationsWhenTheyHappen) {
  // The counter itself must work, or the test above proves nothing.
  testing::start_counting_allocations();
  auto* v = new std::vector<int>(100);
  testing::allocation_sink = v->data();
  Image<float> img(64, 64);
  testing::allocation_sink = img.data();
  const testing::AllocationCounts counts = testing::stop_counting_allocations();
  delete v;
  EXPECT_GE(counts.new_calls, 2);
  if (!testing::kCountsAlignedAlloc)
    GTEST_SKIP() << "aligned_alloc is not counted under a sanitizer";
  EXPECT_EQ(counts.aligned_alloc_calls, 1);
}

TEST(CpuStereoMatcher, ReportsParamsAndTimings) {
  StereoParams params;
  params.max_disparity = 40;
  params.uniqueness = 0.2;
  const auto matcher = make_cpu_stereo_matcher(params);
  EXPECT_EQ(matcher->params().max_disparity, 40);
  EXPECT_EQ(matcher->params().uniqueness, 0.2);
  const Scene s = small_scene(1);
  Image<float> disp;
  matcher->compute(s.left.cview(), s.right.cview(), disp);
  const StereoTimings& t = matcher->last_timings();
  for (double ms : {t.prepare_ms, t.arms_ms, t.initial_ms, t.refine_ms, t.sparse_ms, t.boundary_ms})
    EXPECT_GE(ms, 0.0);
  EXPECT_GT(t.total_ms, 0.0);
  EXPECT_NEAR(t.total_ms,
              t.prepare_ms + t.arms_ms + t.initial_ms + t.refine_ms + t.sparse_ms + t.boundary_ms,
              1e-6 + 1e-9 * t.total_ms);
}

}  // namespace
}  // namespace dco::stereo
