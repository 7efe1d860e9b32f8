#include "dco/pipeline/contour/contour_extractor.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/error.hpp"
#include "dco/core/image.hpp"
#include "dco/kernels/canny_kernels.hpp"
#include "dco/pipeline/contour/gated_canny.hpp"
#include "dco/pipeline/contour/stereo_cue.hpp"
#include "support/same_bytes.hpp"

namespace dco::contour {
namespace {

using ::testing::HasSubstr;

// A textured square sliding right over a textured still background. Frames are cut from the same
// two textures, so every frame pair is an exact shift; the internal frames are the input frames
// at half size, as the pipeline feeds them.
constexpr int kInW = 512, kInH = 384;  // input resolution
constexpr int kW = kInW / 2, kH = kInH / 2;
constexpr int kSquareX = 80, kSquareY = 48, kSide = 96;  // centre frame, internal px
constexpr int kStep = 3;                                 // internal px per frame

cv::Mat texture(int w, int h, int seed) {
  cv::Mat t(h, w, CV_8U);
  cv::RNG rng(seed);
  rng.fill(t, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(t, t, {0, 0}, 2.0);  // camera-like texture that optical flow can follow
  cv::normalize(t, t, 0, 255, cv::NORM_MINMAX);
  return t;
}

struct Frame {
  Image<std::uint8_t> input;     // input resolution
  Image<std::uint8_t> internal;  // half size
};

Frame frame_at(int t) {
  static const cv::Mat background = texture(kInW, kInH, 1);
  static const cv::Mat square = texture(2 * kSide, 2 * kSide, 2);
  cv::Mat img = background.clone();
  square.copyTo(img(cv::Rect(2 * (kSquareX + kStep * t), 2 * kSquareY, 2 * kSide, 2 * kSide)));
  cv::Mat half;
  cv::resize(img, half, {kW, kH}, 0, 0, cv::INTER_AREA);
  Frame f{Image<std::uint8_t>(kInW, kInH), Image<std::uint8_t>(kW, kH)};
  f.input.copy_from(as_view<std::uint8_t>(static_cast<const cv::Mat&>(img)));
  f.internal.copy_from(as_view<std::uint8_t>(static_cast<const cv::Mat&>(half)));
  return f;
}

struct MovingSquare {
  Frame past = frame_at(-1), centre = frame_at(0), future = frame_at(1);
  ContourInputs inputs() const {
    ContourInputs in;
    in.image = centre.input.view();
    in.centre = centre.internal.view();
    in.neighbour_a = past.internal.view();
    in.neighbour_b = future.internal.view();
    return in;
  }
};

// Chebyshev distance (internal px) from (x, y) to the square's outline in the centre frame: the
// nearest of its four sides.
int distance_to_outline(int x, int y) {
  const int x0 = kSquareX, x1 = kSquareX + kSide, y0 = kSquareY, y1 = kSquareY + kSide;
  auto outside = [](int v, int lo, int hi) { return v < lo ? lo - v : v > hi ? v - hi : 0; };
  const int horizontal_sides =
      std::max(outside(x, x0, x1), std::min(std::abs(y - y0), std::abs(y - y1)));
  const int vertical_sides =
      std::max(outside(y, y0, y1), std::min(std::abs(x - x0), std::abs(x - x1)));
  return std::min(horizontal_sides, vertical_sides);
}

// Mean of m_fuse on the outline (within 2 px), and inside and outside the square at least `far`
// px from it.
struct Means {
  double outline = 0, inside = 0, outside = 0;
};

Means region_means(const Image<float>& m, int far) {
  double s[3] = {0, 0, 0};
  int n[3] = {0, 0, 0};
  for (int y = 0; y < m.height(); ++y)
    for (int x = 0; x < m.width(); ++x) {
      const int d = distance_to_outline(x, y);
      const bool inside =
          x > kSquareX && x < kSquareX + kSide && y > kSquareY && y < kSquareY + kSide;
      const int k = d <= 2 ? 0 : d < far ? -1 : inside ? 1 : 2;
      if (k < 0) continue;
      s[k] += m.at(x, y);
      ++n[k];
    }
  return {s[0] / n[0], s[1] / n[1], s[2] / n[2]};
}

// The flow cue is as sharp as the DIS preset's flow: "fast" estimates at 1/4 of the internal
// resolution and smears the motion boundary over ~20 px, "medium" at 1/2 over ~10 px.
TEST(ContourExtractor, FlowCueMarksTheMovingSquaresOutlineAndNotItsTexture) {
  const MovingSquare scene;
  for (const auto& [preset, far] : {std::pair{"fast", 28}, std::pair{"medium", 16}}) {
    ContourParams params;
    params.dis_preset = preset;
    ContourOutputs out;
    make_cpu_contour_extractor(params)->compute(scene.inputs(), out);
    ASSERT_EQ(out.m_fuse.width(), kW);
    ASSERT_EQ(out.m_fuse.height(), kH);
    const Means m = region_means(out.m_fuse, far);
    std::printf("%s: m_fuse mean on the outline %.3f, >= %d px inside %.3f, outside %.3f\n", preset,
                m.outline, far, m.inside, m.outside);
    EXPECT_GT(m.outline, 0.5) << preset;
    EXPECT_LT(m.inside, 0.03) << preset;
    EXPECT_LT(m.outside, 0.01) << preset;
    float largest = 0;
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        ASSERT_GE(out.m_fuse.at(x, y), 0.0f);
        largest = std::max(largest, out.m_fuse.at(x, y));
      }
    EXPECT_FLOAT_EQ(largest, 1.0f) << preset;  // 3 px per frame is well above flow_floor
  }
}

// A still scene seen with sensor noise: DIS returns a few hundredths of a pixel of noise. Divided
// by its own maximum (the paper's normalisation, flow_floor 0) that noise becomes a full-strength
// filter and every texture edge passes; the default floor keeps it below T_depth.
TEST(ContourExtractor, FlowFloorKeepsAStillScenesNoiseOutOfTheGate) {
  const Frame still = frame_at(0);
  Image<std::uint8_t> noisy[2] = {Image<std::uint8_t>(kW, kH), Image<std::uint8_t>(kW, kH)};
  cv::RNG rng(4);
  for (Image<std::uint8_t>& n : noisy) {
    cv::Mat noise(kH, kW, CV_16S), sum;
    rng.fill(noise, cv::RNG::NORMAL, 0, 2);
    as_mat(still.internal.view()).convertTo(sum, CV_16S);
    sum += noise;
    sum.convertTo(as_mat(n.view()), CV_8U);
  }
  ContourInputs in;
  in.image = still.input.view();
  in.centre = still.internal.view();
  in.neighbour_a = noisy[0].view();
  in.neighbour_b = noisy[1].view();
  auto largest = [](const Image<float>& m) {
    float v = 0;
    for (int y = 0; y < m.height(); ++y)
      for (int x = 0; x < m.width(); ++x) v = std::max(v, m.at(x, y));
    return v;
  };
  auto edges = [](const Image<std::uint8_t>& c) {
    int n = 0;
    for (int y = 0; y < c.height(); ++y)
      for (int x = 0; x < c.width(); ++x) n += c.at(x, y) == 255;
    return n;
  };
  ContourOutputs with_floor, without;
  make_cpu_contour_extractor({})->compute(in, with_floor);
  ContourParams paper;
  paper.flow_floor = 0;
  make_cpu_contour_extractor(paper)->compute(in, without);
  EXPECT_LT(largest(with_floor.m_fuse), 0.03f);
  EXPECT_EQ(edges(with_floor.contours), 0);
  EXPECT_FLOAT_EQ(largest(without.m_fuse), 1.0f);
  EXPECT_GT(edges(without.contours), 10000);
}

// Share of contour pixels (input resolution) farther than `far` internal px from the outline, and
// the share of the outline (sampled every internal px) that has a contour pixel within 2 input px.
struct ContourStats {
  int total = 0;
  double off_outline = 0, outline_covered = 0;
};

ContourStats contour_stats(const Image<std::uint8_t>& c, int far) {
  ContourStats s;
  int off = 0;
  for (int y = 0; y < c.height(); ++y)
    for (int x = 0; x < c.width(); ++x)
      if (c.at(x, y) == 255) {
        ++s.total;
        off += distance_to_outline(x / 2, y / 2) > far;
      }
  s.off_outline = s.total ? static_cast<double>(off) / s.total : 0;
  int samples = 0, hit = 0;
  auto covered = [&](int ix, int iy) {
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx)
        if (c.at(std::clamp(ix + dx, 0, kInW - 1), std::clamp(iy + dy, 0, kInH - 1)) == 255)
          return true;
    return false;
  };
  for (int i = 1; i < kSide; ++i)
    for (const auto& [ix, iy] : {std::pair{2 * (kSquareX + i), 2 * kSquareY},
                                 std::pair{2 * (kSquareX + i), 2 * (kSquareY + kSide)},
                                 std::pair{2 * kSquareX, 2 * (kSquareY + i)},
                                 std::pair{2 * (kSquareX + kSide), 2 * (kSquareY + i)}}) {
      ++samples;
      hit += covered(ix, iy);
    }
  s.outline_covered = static_cast<double>(hit) / samples;
  return s;
}

TEST(ContourExtractor, GateKeepsTheOutlineAndDropsTextureEdges) {
  const MovingSquare scene;
  ContourParams open;
  open.t_depth = 0;  // plain Canny
  ContourOutputs plain;
  make_cpu_contour_extractor(open)->compute(scene.inputs(), plain);
  const ContourStats p = contour_stats(plain.contours, 12);
  std::printf("plain Canny: %d px, %.1f%% farther than 12 px from the outline\n", p.total,
              100 * p.off_outline);
  EXPECT_GT(p.off_outline, 0.7);  // the texture is full of intensity edges
  EXPECT_GT(p.outline_covered, 0.95);
  for (const auto& [preset, far, max_off] :
       {std::tuple{"fast", 24, 0.03}, std::tuple{"medium", 12, 0.05}}) {
    ContourParams params;
    params.dis_preset = preset;
    ContourOutputs gated;
    make_cpu_contour_extractor(params)->compute(scene.inputs(), gated);
    const ContourStats g = contour_stats(gated.contours, far);
    std::printf("%s: %d px, %.1f%% farther than %d px from the outline, outline covered %.1f%%\n",
                preset, g.total, 100 * g.off_outline, far, 100 * g.outline_covered);
    EXPECT_LT(g.off_outline, max_off) << preset;
    EXPECT_GT(g.outline_covered, 0.95) << preset;
  }
}

TEST(ContourExtractor, StereoCueAloneMarksADisparityStep) {
  const Frame f = frame_at(0);
  Image<float> disparity(kW, kH);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) disparity.at(x, y) = x < kW / 2 ? 8.0f : 20.0f;
  disparity.at(10, 10) = std::numeric_limits<float>::infinity();  // a hole is no edge
  ContourInputs in;
  in.image = f.input.view();
  in.centre = f.internal.view();
  in.disparity = disparity.view();
  ContourOutputs out;
  make_cpu_contour_extractor({})->compute(in, out);
  // Box 9 around the 2-px line of jumps: 2 / 9 of full strength on the line, 0 beyond 4 px.
  EXPECT_NEAR(out.m_fuse.at(kW / 2, kH / 2), 2.0f / 9.0f, 1e-5f);
  EXPECT_NEAR(out.m_fuse.at(kW / 2 - 5, kH / 2), 1.0f / 9.0f, 1e-5f);
  EXPECT_EQ(out.m_fuse.at(kW / 2 - 6, kH / 2), 0.0f);
  EXPECT_EQ(out.m_fuse.at(kW / 2 + 5, kH / 2), 0.0f);
  EXPECT_EQ(out.m_fuse.at(10, 10), 0.0f);
  int near = 0, far = 0;
  for (int y = 0; y < kInH; ++y)
    for (int x = 0; x < kInW; ++x)
      if (out.contours.at(x, y) == 255) (std::abs(x / 2 - kW / 2) <= 5 ? near : far)++;
  EXPECT_GT(near, 0);
  EXPECT_EQ(far, 0);
}

TEST(ContourExtractor, FusedFilterIsTheLargerOfBothCues) {
  const MovingSquare scene;
  Image<float> disparity(kW, kH);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) disparity.at(x, y) = y < 20 ? 5.0f : 30.0f;
  ContourInputs in = scene.inputs();
  ContourOutputs flow_only, both;
  make_cpu_contour_extractor({})->compute(in, flow_only);
  in.disparity = disparity.view();
  make_cpu_contour_extractor({})->compute(in, both);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      // Rows 19 and 20 carry full-strength jumps; the 9x9 box averages the ones it covers.
      const int rows = (std::abs(y - 19) <= 4) + (std::abs(y - 20) <= 4);
      const float stereo = static_cast<float>(rows) / 9.0f;
      const float expected = std::max(flow_only.m_fuse.at(x, y), stereo);
      ASSERT_NEAR(both.m_fuse.at(x, y), expected, 1e-5f) << x << "," << y;
    }
}

TEST(ContourExtractor, WithoutAnyCueNothingPassesTheGate) {
  const MovingSquare scene;
  ContourInputs in = scene.inputs();
  in.neighbour_b = {};  // one neighbour only: no flow cue
  ContourOutputs out;
  make_cpu_contour_extractor({})->compute(in, out);
  int edges = 0;
  for (int y = 0; y < kInH; ++y)
    for (int x = 0; x < kInW; ++x) edges += out.contours.at(x, y) == 255;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) ASSERT_EQ(out.m_fuse.at(x, y), 0.0f);
  EXPECT_EQ(edges, 0);
  // The intensity gradient is still there for the stages that follow.
  float largest = 0;
  for (int y = 0; y < kInH; ++y)
    for (int x = 0; x < kInW; ++x) largest = std::max(largest, out.m_intensity.at(x, y));
  EXPECT_GT(largest, 0.1f);
  EXPECT_LE(largest, 1.0f);

  ContourParams no_flow;
  no_flow.use_flow = false;
  make_cpu_contour_extractor(no_flow)->compute(scene.inputs(), out);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) ASSERT_EQ(out.m_fuse.at(x, y), 0.0f);
}

TEST(ContourExtractor, OutputsFollowTheInputSizes) {
  // 3:1 with an odd internal size, and 1:1.
  for (const auto& [iw, ih, cw, ch] :
       {std::array{603, 297, 201, 99}, std::array{128, 96, 128, 96}}) {
    cv::Mat big(ih, iw, CV_8U), small(ch, cw, CV_8U);
    cv::RNG(3).fill(big, cv::RNG::UNIFORM, 0, 256);
    cv::resize(big, small, small.size(), 0, 0, cv::INTER_AREA);
    ContourInputs in;
    in.image = as_view<std::uint8_t>(static_cast<const cv::Mat&>(big));
    in.centre = as_view<std::uint8_t>(static_cast<const cv::Mat&>(small));
    in.neighbour_a = in.centre;
    in.neighbour_b = in.centre;
    ContourOutputs out;
    make_cpu_contour_extractor({})->compute(in, out);
    EXPECT_EQ(out.m_fuse.width(), cw);
    EXPECT_EQ(out.m_fuse.height(), ch);
    EXPECT_EQ(out.m_intensity.width(), iw);
    EXPECT_EQ(out.m_intensity.height(), ih);
    EXPECT_EQ(out.contours.width(), iw);
    EXPECT_EQ(out.contours.height(), ih);
    for (int y = 0; y < ih; ++y)
      for (int x = 0; x < iw; ++x) {
        const std::uint8_t c = out.contours.at(x, y);
        ASSERT_TRUE(c == 0 || c == 255);
      }
  }
}

// dco::Image pads rows to 64 bytes; DIS wants continuous rows, so such views go through a copy.
TEST(ContourExtractor, AcceptsPaddedViews) {
  const MovingSquare scene;
  constexpr int kCrop = kW - 3;  // 253 columns: rows padded to 256
  Image<std::uint8_t> padded[3] = {Image<std::uint8_t>(kCrop, kH), Image<std::uint8_t>(kCrop, kH),
                                   Image<std::uint8_t>(kCrop, kH)};
  cv::Mat dense[3];
  const Frame* frames[3] = {&scene.past, &scene.centre, &scene.future};
  for (int i = 0; i < 3; ++i) {
    padded[i].copy_from(frames[i]->internal.view().sub(0, 0, kCrop, kH));
    dense[i] = as_mat(padded[i].view()).clone();
    ASSERT_FALSE(as_mat(padded[i].view()).isContinuous());
  }
  ContourInputs in = scene.inputs();
  in.image = scene.centre.input.view().sub(0, 0, 2 * kCrop, kInH);
  in.neighbour_a = padded[0].view();
  in.centre = padded[1].view();
  in.neighbour_b = padded[2].view();
  ContourOutputs a, b;
  make_cpu_contour_extractor({})->compute(in, a);
  in.neighbour_a = as_view<std::uint8_t>(static_cast<const cv::Mat&>(dense[0]));
  in.centre = as_view<std::uint8_t>(static_cast<const cv::Mat&>(dense[1]));
  in.neighbour_b = as_view<std::uint8_t>(static_cast<const cv::Mat&>(dense[2]));
  make_cpu_contour_extractor({})->compute(in, b);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kCrop; ++x) ASSERT_EQ(a.m_fuse.at(x, y), b.m_fuse.at(x, y));
}

TEST(ContourExtractor, IsDeterministicAndReusable) {
  const MovingSquare scene;
  const auto a = make_cpu_contour_extractor({});
  const auto b = make_cpu_contour_extractor({});
  ContourOutputs first, second, other;
  a->compute(scene.inputs(), first);
  a->compute(scene.inputs(), second);
  b->compute(scene.inputs(), other);
  for (const ContourOutputs* o : {&second, &other}) {
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) ASSERT_EQ(o->m_fuse.at(x, y), first.m_fuse.at(x, y));
    for (int y = 0; y < kInH; ++y)
      for (int x = 0; x < kInW; ++x) {
        ASSERT_EQ(o->m_intensity.at(x, y), first.m_intensity.at(x, y));
        ASSERT_EQ(o->contours.at(x, y), first.contours.at(x, y));
      }
  }
}

TEST(ContourExtractor, FlowFieldsOnTwoThreadsGiveTheSameOutputs) {
  const MovingSquare scene;
  ContourParams serial_params, parallel_params;
  serial_params.parallel_flow = "off";
  parallel_params.parallel_flow = "on";
  const auto serial = make_cpu_contour_extractor(serial_params);
  const auto parallel = make_cpu_contour_extractor(parallel_params);
  ContourOutputs expected, actual;
  serial->compute(scene.inputs(), expected);
  // Twice: the worker thread waits between frames and takes the next one.
  for (int round = 0; round < 2; ++round) {
    parallel->compute(scene.inputs(), actual);
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) ASSERT_EQ(actual.m_fuse.at(x, y), expected.m_fuse.at(x, y));
    for (int y = 0; y < kInH; ++y)
      for (int x = 0; x < kInW; ++x) {
        ASSERT_EQ(actual.m_intensity.at(x, y), expected.m_intensity.at(x, y));
        ASSERT_EQ(actual.contours.at(x, y), expected.contours.at(x, y));
      }
  }
  // The cue is not empty, so equal outputs say something about the flow.
  float top = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) top = std::max(top, expected.m_fuse.at(x, y));
  EXPECT_GT(top, 0.5f);
}

// contour.row_threads shares the flow cue's steps after DIS among threads: the same outputs,
// frame after frame, whether the blocks of rows are many or fewer than the threads.
TEST(ContourExtractor, RowThreadsGiveTheOutputsOfOneThread) {
  const MovingSquare scene;
  ContourParams one_params;
  one_params.row_threads = 1;
  const auto one = make_cpu_contour_extractor(one_params);
  ContourOutputs expected, actual;
  one->compute(scene.inputs(), expected);
  for (const int threads : {2, 3, 16}) {
    ContourParams params;
    params.row_threads = threads;
    const auto many = make_cpu_contour_extractor(params);
    for (int round = 0; round < 2; ++round) {
      many->compute(scene.inputs(), actual);
      for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x)
          ASSERT_EQ(actual.m_fuse.at(x, y), expected.m_fuse.at(x, y)) << threads << " threads";
      for (int y = 0; y < kInH; ++y)
        for (int x = 0; x < kInW; ++x)
          ASSERT_EQ(actual.contours.at(x, y), expected.contours.at(x, y)) << threads << " threads";
    }
  }
  float top = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) top = std::max(top, expected.m_fuse.at(x, y));
  EXPECT_GT(top, 0.5f);
}

// The window centred on frame -1, which the scene's window follows; `earlier` is frame -2.
ContourInputs window_before(const MovingSquare& scene, const Frame& earlier) {
  ContourInputs in;
  in.image = scene.past.input.view();
  in.centre = scene.past.internal.view();
  in.neighbour_a = earlier.internal.view();
  in.neighbour_b = scene.centre.internal.view();
  return in;
}

// A window that follows the last one runs DIS once, and the cue stays what two DIS runs give.
// With lookahead 1, (t-1, t, t+1) after (t-2, t-1, t): the field t -> t-1 is the last call's
// t-1 -> t turned round. With lookahead 0, (t-2, t-1, t) after (t-3, t-2, t-1): the field
// t -> t-2 is the fresh t -> t-1 carried on by the last call's t-1 -> t-2.
TEST(ContourExtractor, ReusesTheLastFieldWhenTheWindowMovesOn) {
  const MovingSquare scene;
  const Frame earlier = frame_at(-2), earliest = frame_at(-3);
  for (const int lookahead : {1, 0}) {
    SCOPED_TRACE("lookahead " + std::to_string(lookahead));
    ContourInputs first = window_before(scene, earlier);
    ContourInputs second = scene.inputs();
    if (lookahead == 0) {
      first.neighbour_a = earlier.internal.view();
      first.neighbour_b = earliest.internal.view();
      second.neighbour_a = scene.past.internal.view();
      second.neighbour_b = earlier.internal.view();
    }
    ContourParams reuse_params;
    reuse_params.lookahead = lookahead;
    ContourParams fresh_params = reuse_params;
    fresh_params.reuse_flow = false;
    const auto reusing = make_cpu_contour_extractor(reuse_params);
    const auto fresh = make_cpu_contour_extractor(fresh_params);
    ContourOutputs out, expected;
    reusing->compute(first, out);
    EXPECT_EQ(reusing->last_timings().dis_fields, 2);
    reusing->compute(second, out);
    EXPECT_EQ(reusing->last_timings().dis_fields, 1);
    fresh->compute(first, expected);
    fresh->compute(second, expected);
    EXPECT_EQ(fresh->last_timings().dis_fields, 2);

    const Means m = region_means(out.m_fuse, 28);
    const Means e = region_means(expected.m_fuse, 28);
    std::printf(
        "lookahead %d, m_fuse on the outline / inside / outside: reused %.3f / %.3f / %.3f, two "
        "DIS runs %.3f / %.3f / %.3f\n",
        lookahead, m.outline, m.inside, m.outside, e.outline, e.inside, e.outside);
    EXPECT_GT(m.outline, 0.9 * e.outline);
    EXPECT_LT(m.inside, 0.03);
    EXPECT_LT(m.outside, 0.01);
    // The gate may differ near the threshold, but it opens no more often away from the outline
    // (texture inside the moving square, where the smeared flow is not quite constant).
    int differ = 0, open_far = 0, expected_open_far = 0;
    double abs_diff = 0;
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        const float a = out.m_fuse.at(x, y), b = expected.m_fuse.at(x, y);
        differ += (a >= 0.03f) != (b >= 0.03f);
        const bool far = distance_to_outline(x, y) >= 28;
        open_far += far && a >= 0.03f;
        expected_open_far += far && b >= 0.03f;
        abs_diff += std::fabs(a - b);
      }
    std::printf(
        "gate differs on %d of %d px, open 28 px or more from the outline on %d px (two DIS "
        "runs: %d), mean |difference| %.4f\n",
        differ, kW * kH, open_far, expected_open_far, abs_diff / (kW * kH));
    EXPECT_LT(differ, kW * kH / 20);
    EXPECT_LE(open_far, expected_open_far + expected_open_far / 4 + 50);
    EXPECT_LT(abs_diff / (kW * kH), 0.014);

    // The same window again does not follow the last one: two DIS runs.
    reusing->compute(second, out);
    EXPECT_EQ(reusing->last_timings().dis_fields, 2);
  }
}

// prepare_next makes the next window's field to the previous frame (the last field turned round)
// and its steps up to the fusion ahead of compute: the same outputs as compute making them. A
// window that does not follow the last one leaves what was prepared unused.
TEST(ContourExtractor, PreparedNextStepsGiveTheSameOutputs) {
  const MovingSquare scene;
  const Frame earlier = frame_at(-2);
  const ContourInputs first = window_before(scene, earlier);
  const auto same_outputs = [](const ContourOutputs& a, const ContourOutputs& b) {
    return dco::testing::same_bytes(a.m_fuse, b.m_fuse) &&
           dco::testing::same_bytes(a.contours, b.contours);
  };
  ContourParams centred;  // prepare_next has work with the centred window
  centred.lookahead = 1;
  const auto plain = make_cpu_contour_extractor(centred);
  const auto prepared = make_cpu_contour_extractor(centred);
  ContourOutputs expected, actual;
  EXPECT_FALSE(prepared->prepare_next()) << "nothing before the first window";
  plain->compute(first, expected);
  prepared->compute(first, actual);
  ASSERT_TRUE(same_outputs(actual, expected));
  EXPECT_TRUE(prepared->prepare_next());
  plain->compute(scene.inputs(), expected);
  prepared->compute(scene.inputs(), actual);
  EXPECT_EQ(prepared->last_timings().dis_fields, 1);
  EXPECT_TRUE(same_outputs(actual, expected)) << "the window that follows";
  // Prepared from the window centred on 0, then given that window again (not its successor):
  // its own two fields, as without the preparation.
  EXPECT_TRUE(prepared->prepare_next());
  plain->compute(scene.inputs(), expected);
  prepared->compute(scene.inputs(), actual);
  EXPECT_EQ(prepared->last_timings().dis_fields, 2);
  EXPECT_TRUE(same_outputs(actual, expected)) << "a window that does not follow";
  // And the preparation is gone: the next window that follows makes its own steps again.
  plain->compute(first, expected);
  prepared->compute(first, actual);
  plain->compute(scene.inputs(), expected);
  prepared->compute(scene.inputs(), actual);
  EXPECT_TRUE(same_outputs(actual, expected)) << "after an unused preparation";
  // No flow cue (or no reused field): nothing to prepare.
  ContourParams no_flow;
  no_flow.use_flow = false;
  const auto without_flow = make_cpu_contour_extractor(no_flow);
  without_flow->compute(first, actual);
  EXPECT_FALSE(without_flow->prepare_next());
  ContourParams causal;
  causal.lookahead = 0;
  const auto causal_extractor = make_cpu_contour_extractor(causal);
  causal_extractor->compute(first, actual);
  EXPECT_FALSE(causal_extractor->prepare_next());
}

TEST(ContourExtractor, ReportsEveryStepsTime) {
  const MovingSquare scene;
  const auto extractor = make_cpu_contour_extractor({});
  ContourOutputs out;
  extractor->compute(scene.inputs(), out);
  const ContourTimings& t = extractor->last_timings();
  EXPECT_GT(t.flow_ms, 0);
  EXPECT_GT(t.amplitude_ms, 0);
  EXPECT_GT(t.fusion_ms, 0);
  EXPECT_GT(t.box_ms, 0);
  EXPECT_GT(t.normalise_ms, 0);
  EXPECT_EQ(t.stereo_cue_ms, 0);  // no disparity given
  EXPECT_GT(t.gaussian_ms, 0);
  EXPECT_GT(t.canny_ms, 0);
  // The steps account for the total. A preemption between two of them adds milliseconds that no
  // step owns on a busy machine, so the least untimed remainder of up to three runs is compared.
  double untimed = 1e9;
  for (int run = 0; run < 3 && untimed >= 5.0; ++run) {
    if (run > 0) extractor->compute(scene.inputs(), out);
    const ContourTimings& r = extractor->last_timings();
    const double parts = r.flow_ms + r.amplitude_ms + r.fusion_ms + r.box_ms + r.normalise_ms +
                         r.stereo_cue_ms + r.gaussian_ms + r.canny_ms;
    EXPECT_GE(r.total_ms, parts * 0.999);
    untimed = std::min(untimed, r.total_ms - parts);
  }
  EXPECT_LT(untimed, 5.0);
}

std::string compute_error(const ContourInputs& in) {
  ContourOutputs out;
  try {
    make_cpu_contour_extractor({})->compute(in, out);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(ContourExtractor, RejectsInconsistentInputs) {
  const MovingSquare scene;
  Image<std::uint8_t> colour(kInW, kInH, 3), odd(kW + 1, kH);
  Image<float> disparity(kW, kH - 1);
  colour.fill(0);
  odd.fill(0);
  disparity.fill(0);
  ContourInputs in = scene.inputs();
  in.image = {};
  EXPECT_THAT(compute_error(in), HasSubstr("input image"));
  in = scene.inputs();
  in.image = colour.view();
  EXPECT_THAT(compute_error(in), HasSubstr("grey"));
  in = scene.inputs();
  in.centre = {};
  EXPECT_THAT(compute_error(in), HasSubstr("centre"));
  in = scene.inputs();
  in.neighbour_b = odd.view();
  EXPECT_THAT(compute_error(in), HasSubstr("neighbour_b is 257x192x1, expected 256x192x1"));
  in = scene.inputs();
  in.disparity = disparity.view();
  EXPECT_THAT(compute_error(in), HasSubstr("disparity"));
  in = scene.inputs();
  in.image = scene.centre.internal.view();
  in.centre = scene.centre.input.view();
  EXPECT_THAT(compute_error(in), HasSubstr("larger than the input image"));
  // Gradients the caller made: both, of the input image's size.
  Image<float> m_intensity(kInW, kInH), small_m(kInW, kInH - 1);
  Image<std::uint8_t> direction(kInW, kInH);
  m_intensity.fill(0);
  small_m.fill(0);
  direction.fill(0);
  in = scene.inputs();
  in.m_intensity = m_intensity.view();
  EXPECT_THAT(compute_error(in), HasSubstr("m_intensity and direction come together"));
  in.direction = direction.view();
  EXPECT_EQ(compute_error(in), "");
  in.m_intensity = small_m.view();
  EXPECT_THAT(compute_error(in), HasSubstr("m_intensity is"));
  in = scene.inputs();
  in.stereo_cue = disparity.view();  // one row short
  EXPECT_THAT(compute_error(in), HasSubstr("stereo_cue is"));
  in = scene.inputs();
  Image<std::uint8_t> classes(kInW - 1, kInH);
  classes.fill(0);
  in.canny_classes = classes.view();
  EXPECT_THAT(compute_error(in), HasSubstr("canny_classes is"));
}

// Given the image's gradients and Canny classes (intensity_gradients_and_classes) and the stereo
// cue (stereo_cue), as the real-time runtime's stereo thread makes them, the stage gives the same
// M_fuse and contours with and without the flow cue, leaves out.m_intensity alone and reports no
// time for the gradients. It gates the classes it is given rather than classifying again.
TEST(ContourExtractor, TakesTheGradientsAndStereoCueTheCallerMade) {
  const MovingSquare scene;
  const ContourParams params;
  // A disparity step inside the frame: the stereo cue marks it.
  Image<float> disparity(kW, kH);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) disparity.at(x, y) = x < kW / 3 ? 20.0f : 8.0f;
  GradientScratch scratch;
  Image<float> m_intensity, cue;
  Image<std::uint8_t> direction, classes;
  StereoCueScratch cue_scratch;
  for (const bool flow : {true, false}) {
    ContourInputs in = scene.inputs();
    in.disparity = disparity.cview();
    if (!flow) in.neighbour_a = in.neighbour_b = {};
    const auto extractor = make_cpu_contour_extractor(params);
    ContourOutputs expected, given_out;
    extractor->compute(in, expected);
    intensity_gradients_and_classes(in.image, CannyThresholds{}, scratch, m_intensity, direction,
                                    classes);
    stereo_cue(in.disparity, static_cast<float>(params.stereo_jump), params.box_size, cue_scratch,
               cue);
    EXPECT_TRUE(dco::testing::same_bytes(m_intensity, expected.m_intensity));
    in.m_intensity = m_intensity.cview();
    in.direction = direction.cview();
    in.stereo_cue = cue.cview();
    in.canny_classes = classes.cview();
    given_out.m_intensity = Image<float>(3, 2);
    given_out.m_intensity.fill(7.0f);
    extractor->compute(in, given_out);
    EXPECT_TRUE(dco::testing::same_bytes(given_out.m_fuse, expected.m_fuse)) << flow;
    EXPECT_TRUE(dco::testing::same_bytes(given_out.contours, expected.contours)) << flow;
    EXPECT_EQ(given_out.m_intensity.width(), 3);
    EXPECT_EQ(given_out.m_intensity.at(2, 1), 7.0f);
    EXPECT_EQ(extractor->last_timings().gaussian_ms, 0);
    // Not trivially equal: the step shows in the filter.
    EXPECT_GT(given_out.m_fuse.at(kW / 3, kH / 2), 0.2f) << flow;  // 2 of 9 columns jump
    // The classes given are the ones gated: without a single edge class, no contour.
    Image<std::uint8_t> no_classes(classes.width(), classes.height());
    no_classes.fill(kernels::kCannyNone);
    in.canny_classes = no_classes.cview();
    ContourOutputs none_out;
    extractor->compute(in, none_out);
    int edges = 0, none = 0;
    for (int y = 0; y < kInH; ++y)
      for (int x = 0; x < kInW; ++x)
        edges += expected.contours.at(x, y) != 0, none += none_out.contours.at(x, y) != 0;
    EXPECT_GT(edges, 0) << flow;
    EXPECT_EQ(none, 0) << flow;
  }
}

// The flow cue of a window made on its own (flow_cue, which reads no disparity) and handed to
// compute() gives compute()'s own outputs, with the flow steps' times reported by the first call.
TEST(ContourExtractor, AFlowCueMadeAheadGivesTheSameOutputs) {
  const MovingSquare scene;
  Image<float> disparity(kW, kH);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) disparity.at(x, y) = x < kW / 3 ? 20.0f : 8.0f;
  for (const int lookahead : {0, 1}) {
    for (const bool stereo : {true, false}) {
      SCOPED_TRACE("lookahead " + std::to_string(lookahead) + (stereo ? ", stereo cue" : ""));
      ContourParams params;
      params.lookahead = lookahead;
      ContourInputs in = scene.inputs();
      if (stereo) in.disparity = disparity.cview();
      const auto plain = make_cpu_contour_extractor(params);
      const auto ahead = make_cpu_contour_extractor(params);
      ContourOutputs expected, actual;
      plain->compute(in, expected);
      Image<float> cue;
      ContourTimings times;
      ContourInputs window;  // the images alone: no input image, no disparity
      window.centre = in.centre;
      window.neighbour_a = in.neighbour_a;
      window.neighbour_b = in.neighbour_b;
      ahead->flow_cue(window, cue, times);
      EXPECT_EQ(times.dis_fields, 2);
      EXPECT_GT(times.flow_ms, 0.0);
      EXPECT_GE(times.total_ms, times.flow_ms + times.fusion_ms);
      in.flow_cue = cue.cview();
      ahead->compute(in, actual);
      EXPECT_TRUE(dco::testing::same_bytes(actual.m_fuse, expected.m_fuse));
      EXPECT_TRUE(dco::testing::same_bytes(actual.contours, expected.contours));
      EXPECT_EQ(ahead->last_timings().dis_fields, 0);
      EXPECT_EQ(ahead->last_timings().flow_ms, 0.0);
      if (!stereo) {
        EXPECT_TRUE(dco::testing::same_bytes(actual.m_fuse, cue));
      }
    }
  }
  // Not trivially equal: the cue marks the moving square's outline.
  Image<float> cue;
  ContourTimings times;
  make_cpu_contour_extractor({})->flow_cue(scene.inputs(), cue, times);
  const Means m = region_means(cue, 24);
  EXPECT_GT(m.outline, 4 * m.outside);
}

TEST(ContourExtractor, RejectsAFlowCueItCannotMakeOrUse) {
  const MovingSquare scene;
  const auto error_of = [](const std::function<void()>& f) -> std::string {
    try {
      f();
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  Image<float> cue, short_cue(kW, kH - 1);
  short_cue.fill(0.0f);
  ContourTimings times;
  ContourOutputs out;
  ContourParams no_flow;
  no_flow.use_flow = false;
  const auto extractor = make_cpu_contour_extractor({});
  const auto without_flow = make_cpu_contour_extractor(no_flow);
  EXPECT_THAT(error_of([&] { without_flow->flow_cue(scene.inputs(), cue, times); }),
              HasSubstr("use_flow off"));
  ContourInputs in = scene.inputs();
  in.neighbour_b = {};
  EXPECT_THAT(error_of([&] { extractor->flow_cue(in, cue, times); }),
              HasSubstr("needs both neighbours"));
  in = scene.inputs();
  in.centre = {};
  EXPECT_THAT(error_of([&] { extractor->flow_cue(in, cue, times); }), HasSubstr("centre frame"));
  Image<std::uint8_t> odd(kW + 1, kH);
  odd.fill(0);
  in = scene.inputs();
  in.neighbour_a = odd.view();
  EXPECT_THAT(error_of([&] { extractor->flow_cue(in, cue, times); }),
              HasSubstr("neighbour_a is 257x192x1"));
  // Given to compute(): of the internal size, with both neighbours, and only with use_flow.
  in = scene.inputs();
  in.flow_cue = short_cue.cview();
  EXPECT_THAT(error_of([&] { extractor->compute(in, out); }), HasSubstr("flow_cue is"));
  extractor->flow_cue(scene.inputs(), cue, times);
  in.flow_cue = cue.cview();
  in.neighbour_a = {};
  EXPECT_THAT(error_of([&] { extractor->compute(in, out); }), HasSubstr("without both neighbours"));
  in = scene.inputs();
  in.flow_cue = cue.cview();
  EXPECT_THAT(error_of([&] { without_flow->compute(in, out); }), HasSubstr("use_flow off"));
  EXPECT_EQ(error_of([&] { extractor->compute(in, out); }), "");
}

// DIS cannot build its pyramid on small frames; the extractor says so instead of returning garbage.
TEST(ContourExtractor, RejectsFramesTooSmallForTheFlowPreset) {
  const MovingSquare scene;
  ContourInputs in = scene.inputs();
  for (const auto& [w, h] : {std::pair{64, 48}, std::pair{200, 24}}) {
    in.centre = scene.centre.internal.view().sub(0, 0, w, h);
    in.neighbour_a = scene.past.internal.view().sub(0, 0, w, h);
    in.neighbour_b = scene.future.internal.view().sub(0, 0, w, h);
    EXPECT_THAT(compute_error(in), HasSubstr("too small for DIS optical flow with the 'fast'"));
    ContourParams no_flow;
    no_flow.use_flow = false;
    ContourOutputs out;
    EXPECT_NO_THROW(make_cpu_contour_extractor(no_flow)->compute(in, out));
  }
}

}  // namespace
}  // namespace dco::contour
