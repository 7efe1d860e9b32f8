// The step functions DepthPipeline and the runtime share: the prepared grey images are the ones
// the stereo stage works on, and the contour windows are the ones of the offline pipeline.

#include <cstring>

#include <gtest/gtest.h>

#include "dco/core/synthetic_scene.hpp"
#include "dco/pipeline/depth_pipeline.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"
#include "support/same_bytes.hpp"

namespace dco::pipeline {
namespace {

using dco::testing::same_bytes;

TEST(PrepareFrame, InternalGreyEqualsTheStereoStagesOwn) {
  for (const bool color : {false, true})
    for (const char* resolution : {"full", "half"}) {
      synthetic::SceneConfig config = synthetic::preset("boxes", 175, 97);  // odd: dropped edges
      config.color = color;
      const synthetic::SceneRenderer scene(config);
      synthetic::StereoSample s;
      scene.render(1, s);
      stereo::StereoParams params;
      params.max_disparity = 40;
      params.internal_resolution = resolution;
      const auto matcher = stereo::make_cpu_stereo_matcher(params);
      StereoSlot slot;
      prepare_frame(params, s.left.cview(), 7, slot);
      stereo_frame(*matcher, s.left.cview(), s.right.cview(), slot);
      SCOPED_TRACE(std::string(color ? "colour" : "grey") + ", " + resolution);
      EXPECT_EQ(slot.index, 7);
      EXPECT_TRUE(same_bytes(slot.small.cview(), matcher->internal_left_gray()));
      EXPECT_EQ(slot.image.width(), 175);
      EXPECT_EQ(slot.image.channels(), 1);
      EXPECT_EQ(slot.raw_disparity.width(), slot.small.width());
      EXPECT_EQ(slot.sparse.width(), 175);
    }
}

TEST(ContourWindows, CentredWindowTrailsByOneAndCausalWindowLooksBack) {
  const auto expect = [](ContourWindow w, int centre, int a, int b) {
    EXPECT_EQ(w.centre, centre);
    EXPECT_EQ(w.neighbour_a, a);
    EXPECT_EQ(w.neighbour_b, b);
  };
  expect(window_on_arrival(1, 0), -1, -1, -1);
  expect(window_on_arrival(1, 1), 0, -1, 1);
  expect(window_on_arrival(1, 5), 4, 3, 5);
  expect(window_on_arrival(0, 0), 0, -1, -1);
  expect(window_on_arrival(0, 1), 1, 0, -1);
  expect(window_on_arrival(0, 5), 5, 4, 3);
  expect(window_at_end(0), 0, -1, -1);
  expect(window_at_end(5), 5, 4, -1);
}

}  // namespace
}  // namespace dco::pipeline
