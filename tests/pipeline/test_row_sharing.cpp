// The stages' row-wise steps shared with helper threads (stereo/contour/densify.row_threads) in
// the whole pipeline: the same bytes as one thread per stage. Here, not beside each stage's own
// test, so that it runs under ThreadSanitizer with the other threaded parts.

#include <gtest/gtest.h>

#include "dco/core/synthetic_scene.hpp"
#include "dco/pipeline/depth_pipeline.hpp"
#include "support/same_bytes.hpp"

namespace dco::pipeline {
namespace {

using dco::testing::same_bytes;

TEST(RowSharing, ThePipelineGivesTheBytesOfOneThreadPerStage) {
  // Wide enough a search (7 batches of 16) for the guided search and its half-size pass.
  const synthetic::SceneConfig config = synthetic::preset("hand", 320, 180);
  const synthetic::SceneRenderer scene(config);
  PipelineParams one;
  one.stereo.max_disparity = 100;
  one.stereo.internal_resolution = "full";
  one.stereo.search_range = "guided";
  one.stereo.row_threads = one.contour.row_threads = one.densify.row_threads = 1;
  PipelineParams three = one;
  three.stereo.row_threads = three.contour.row_threads = three.densify.row_threads = 3;
  DepthPipeline serial(one), shared(three);
  DepthResult expected, actual;
  int compared = 0;
  for (int i = 0; i < 5; ++i) {
    synthetic::StereoSample s;
    scene.render(i, s);
    const bool a = serial.push(s.left.cview(), s.right.cview(), expected);
    const bool b = shared.push(s.left.cview(), s.right.cview(), actual);
    ASSERT_EQ(a, b);
    if (!a) continue;
    ++compared;
    SCOPED_TRACE(::testing::Message() << "frame " << expected.index);
    EXPECT_TRUE(same_bytes(expected.sparse.cview(), actual.sparse.cview()));
    EXPECT_TRUE(same_bytes(expected.m_fuse.cview(), actual.m_fuse.cview()));
    EXPECT_TRUE(same_bytes(expected.contours.cview(), actual.contours.cview()));
    EXPECT_TRUE(same_bytes(expected.dense.cview(), actual.dense.cview()));
    EXPECT_EQ(expected.solver.iterations, actual.solver.iterations);
    EXPECT_LT(actual.stereo_timings.searched_fraction, 1.0) << "the search was guided";
    EXPECT_EQ(actual.flow_cue, expected.index >= 2);  // the causal window's two predecessors
  }
  EXPECT_EQ(compared, 5);
}

}  // namespace
}  // namespace dco::pipeline
