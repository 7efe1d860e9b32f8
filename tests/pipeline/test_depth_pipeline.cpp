// The offline pipeline: frame bookkeeping of the contour window and a dense result on a
// synthetic sequence whose truth is known.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/pipeline/depth_pipeline.hpp"
#include "support/same_bytes.hpp"

namespace dco::pipeline {
namespace {

synthetic::SceneRenderer small_scene(const char* name) {
  return synthetic::SceneRenderer(synthetic::preset(name, 320, 180));
}

PipelineParams params_for(const synthetic::SceneRenderer& scene) {
  PipelineParams p;
  p.stereo.max_disparity = synthetic::covering_max_disparity(scene.config());
  return p;
}

TEST(DepthPipeline, CentredWindowReleasesEachFrameOneLate) {
  const auto scene = small_scene("hand");
  PipelineParams p = params_for(scene);
  p.contour.lookahead = 1;
  DepthPipeline pipeline(p);
  synthetic::StereoSample s;
  DepthResult r;
  scene.render(0, s);
  EXPECT_FALSE(pipeline.push(s.left.cview(), s.right.cview(), r));
  for (int i = 1; i < 4; ++i) {
    scene.render(i, s);
    ASSERT_TRUE(pipeline.push(s.left.cview(), s.right.cview(), r));
    EXPECT_EQ(r.index, i - 1);
    EXPECT_EQ(r.flow_cue, i - 1 >= 1);  // frame 0 has no predecessor
  }
  ASSERT_TRUE(pipeline.finish(r));
  EXPECT_EQ(r.index, 3);
  EXPECT_FALSE(r.flow_cue);
  EXPECT_FALSE(pipeline.finish(r));
}

TEST(DepthPipeline, CausalWindowReleasesEveryFrameAtOnce) {
  const auto scene = small_scene("hand");
  DepthPipeline pipeline(params_for(scene));  // the default window
  synthetic::StereoSample s;
  DepthResult r;
  for (int i = 0; i < 4; ++i) {
    scene.render(i, s);
    ASSERT_TRUE(pipeline.push(s.left.cview(), s.right.cview(), r));
    EXPECT_EQ(r.index, i);
    EXPECT_EQ(r.flow_cue, i >= 2);
  }
  EXPECT_FALSE(pipeline.finish(r));
}

// The photometric refinement without its smoothness (alpha 0), where its linearised steps run
// farthest.
PipelineParams unsmoothed_refinement() {
  PipelineParams p;
  p.stereo.max_disparity = 32;
  p.densify.photometric.alpha = 0.0;
  return p;
}

// The photometric refinement's linearised steps can run far where the images say little (flat
// ground, no smoothness): what it gives stays within the matches' range.
TEST(DepthPipeline, RefinedMapKeepsToTheRangeOfTheMatches) {
  const auto scene = synthetic::SceneRenderer(synthetic::preset("boxes", 320, 240));
  DepthPipeline pipeline(unsmoothed_refinement());
  synthetic::StereoSample s;
  DepthResult r;
  for (int i = 0; i < 2; ++i) {
    scene.render(i, s);
    if (!pipeline.push(s.left.cview(), s.right.cview(), r)) continue;
    float high = 0.0f;
    for (int y = 0; y < r.sparse.height(); ++y)
      for (int x = 0; x < r.sparse.width(); ++x)
        if (std::isfinite(r.sparse.at(x, y))) high = std::max(high, r.sparse.at(x, y));
    for (int y = 0; y < r.dense.height(); ++y)
      for (int x = 0; x < r.dense.width(); ++x) {
        ASSERT_GE(r.dense.at(x, y), 0.0f) << x << "," << y;
        ASSERT_LE(r.dense.at(x, y), std::max(high, 32.0f)) << x << "," << y;
      }
  }
}

// A right camera that sees nothing (covered by a hand, dead, glared): no match at all. The
// refinement then has no range to keep to, yet must not invent depth where the stage found none.
TEST(DepthPipeline, NoMatchLeavesTheRefinedMapAtZero) {
  const auto scene = synthetic::SceneRenderer(synthetic::preset("boxes", 320, 240));
  DepthPipeline pipeline(unsmoothed_refinement());
  synthetic::StereoSample s;
  DepthResult r;
  int frames = 0;
  for (int i = 0; i < 3; ++i) {
    scene.render(i, s);
    s.right.fill(0);
    if (!pipeline.push(s.left.cview(), s.right.cview(), r)) continue;
    ++frames;
    long matches = 0;
    for (int y = 0; y < r.sparse.height(); ++y)
      for (int x = 0; x < r.sparse.width(); ++x) matches += std::isfinite(r.sparse.at(x, y));
    ASSERT_EQ(matches, 0);
    for (int y = 0; y < r.dense.height(); ++y)
      for (int x = 0; x < r.dense.width(); ++x) ASSERT_EQ(r.dense.at(x, y), 0.0f) << x << "," << y;
  }
  EXPECT_EQ(frames, 3);
}

TEST(DepthPipeline, DenseMapIsCompleteAndMostlyRightOnASyntheticSequence) {
  const auto scene = small_scene("boxes");
  DepthPipeline pipeline(params_for(scene));
  synthetic::StereoSample s, truth;
  DepthResult r;
  long pixels = 0, bad = 0;
  for (int i = 0; i < 4; ++i) {
    scene.render(i, s);
    if (!pipeline.push(s.left.cview(), s.right.cview(), r)) continue;
    scene.render(r.index, truth);
    ASSERT_EQ(r.dense.width(), 320);
    ASSERT_EQ(r.dense.height(), 180);
    EXPECT_TRUE(r.solver.converged);
    for (int y = 0; y < 180; ++y)
      for (int x = 0; x < 320; ++x) {
        ASSERT_TRUE(std::isfinite(r.dense.at(x, y)));
        ++pixels;
        bad += std::abs(r.dense.at(x, y) - truth.disparity.at(x, y)) > 2.0f;
      }
  }
  ASSERT_GT(pixels, 0);
  EXPECT_LT(100.0 * bad / pixels, 10.0);
}

TEST(DepthPipeline, RefusesASizeChangeWithinASequence) {
  const auto scene = small_scene("static");
  const auto other = synthetic::SceneRenderer(synthetic::preset("static", 352, 180));
  DepthPipeline pipeline(params_for(scene));
  synthetic::StereoSample a, b;
  scene.render(0, a);
  other.render(0, b);
  DepthResult r;
  pipeline.push(a.left.cview(), a.right.cview(), r);
  EXPECT_THROW(pipeline.push(b.left.cview(), b.right.cview(), r), Error);
  pipeline.reset();
  ASSERT_TRUE(pipeline.push(b.left.cview(), b.right.cview(), r));  // a new sequence
  EXPECT_EQ(r.index, 0);
  EXPECT_EQ(r.dense.width(), 352);
  EXPECT_FALSE(pipeline.finish(r));
}

// After reset() the pipeline owes nothing to the frames before: the stereo stage's temporal
// guide, the flow window and the stability term start again, as in a new pipeline.
TEST(DepthPipeline, ResetForgetsTheSequenceBefore) {
  const auto scene = small_scene("hand");
  PipelineParams p = params_for(scene);
  p.stereo.search_range = "temporal";
  DepthPipeline used(p), fresh(p);
  synthetic::StereoSample s;
  DepthResult a, b;
  for (int i = 0; i < 4; ++i) {
    scene.render(i, s);
    used.push(s.left.cview(), s.right.cview(), a);
  }
  used.reset();
  for (int i = 20; i < 24; ++i) {
    scene.render(i, s);
    const bool from_used = used.push(s.left.cview(), s.right.cview(), a);
    ASSERT_EQ(from_used, fresh.push(s.left.cview(), s.right.cview(), b));
    if (!from_used) continue;
    EXPECT_EQ(a.index, b.index);
    EXPECT_EQ(a.stereo_timings.searched_fraction, b.stereo_timings.searched_fraction);
    EXPECT_TRUE(testing::same_bytes(a.sparse, b.sparse)) << "frame " << i;
    EXPECT_TRUE(testing::same_bytes(a.dense, b.dense)) << "frame " << i;
  }
}

}  // namespace
}  // namespace dco::pipeline

namespace dco::pipeline {
namespace {

// Whether three frames of this size go through the offline pipeline (the third has a flow
// window).
bool sequence_runs(const PipelineParams& p, int width, int height) {
  Image<std::uint8_t> left(width, height), right(width, height);
  std::uint32_t seed = 12345;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      seed = seed * 1664525u + 1013904223u;
      left.row(y)[x] = static_cast<std::uint8_t>(seed >> 24);
      right.row(y)[x] = static_cast<std::uint8_t>(seed >> 16);
    }
  try {
    DepthPipeline pipeline(p);
    DepthResult r;
    for (int i = 0; i < 3; ++i) pipeline.push(left.cview(), right.cview(), r);
    while (pipeline.finish(r)) {
    }
    return true;
  } catch (const Error&) {
    return false;
  }
}

// A source's size is known before its first frame: check_frame_size refuses exactly the sizes
// whose frames the stages would refuse, so dcod can refuse a configuration before it runs.
TEST(DepthPipeline, CheckFrameSizeRefusesWhatTheStagesWould) {
  int refused = 0, checked = 0;
  for (const auto& [w, h] : std::vector<std::pair<int, int>>{
           {8, 6}, {9, 7}, {24, 12}, {40, 30}, {64, 48}, {100, 20}, {645, 7}, {650, 20}})
    for (const int max_d : {1, 2, 8, 20, 64})
      for (const bool flow : {true, false}) {
        PipelineParams p;
        p.stereo.max_disparity = max_d;
        p.contour.use_flow = flow;
        bool checks = true;
        std::string why;
        try {
          check_frame_size(p, w, h);
        } catch (const Error& e) {
          checks = false;
          why = e.what();
        }
        EXPECT_EQ(checks, sequence_runs(p, w, h))
            << w << "x" << h << ", max_disparity " << max_d << ", use_flow " << flow << ": " << why;
        refused += checks ? 0 : 1;
        ++checked;
      }
  // Every kind of refusal occurs: the census window, the width, half size, DIS.
  EXPECT_GT(refused, 10);
  EXPECT_LT(refused, checked - 10);
  PipelineParams p;
  p.stereo.max_disparity = 20;
  EXPECT_THROW(check_frame_size(p, 20, 96), Error);
  p.contour.use_flow = true;
  try {
    check_frame_size(p, 30, 20);
    ADD_FAILURE() << "a 30x20 frame is too small for DIS";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("DIS optical flow"), std::string::npos) << e.what();
  }
  p.contour.use_flow = false;
  EXPECT_NO_THROW(check_frame_size(p, 30, 20));
}

}  // namespace
}  // namespace dco::pipeline
