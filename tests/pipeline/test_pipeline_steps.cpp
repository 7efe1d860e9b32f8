// The step functions DepthPipeline and the runtime share: the prepared grey images are the ones
// the stereo stage works on, and the contour windows are the ones of the offline pipeline.

#include <cstring>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/pipeline/depth_pipeline.hpp"
#include "dco/pipeline/stereo/exposure_balance.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"
#include "dco/pipeline/stereo/vertical_alignment.hpp"
#include "support/same_bytes.hpp"

namespace dco::pipeline {
namespace {

using dco::testing::same_bytes;

// The densifier refuses `in` with an error that names `what`.
void expect_refused(densify::Densifier& densifier, const densify::DensifyInputs& in,
                    const char* what) {
  Image<float> dense;
  try {
    densifier.compute(in, dense);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr(what));
  }
}

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
      stereo_frame(*matcher, s.left.cview(), s.right.cview(), slot, true);
      SCOPED_TRACE(std::string(color ? "colour" : "grey") + ", " + resolution);
      EXPECT_EQ(slot.index, 7);
      EXPECT_TRUE(same_bytes(slot.small.cview(), matcher->internal_left_gray()));
      EXPECT_EQ(slot.image.width(), 175);
      EXPECT_EQ(slot.image.channels(), 1);
      EXPECT_EQ(slot.raw_disparity.width(), slot.small.width());
      EXPECT_EQ(slot.sparse.width(), 175);
    }
}

TEST(PlaneFrame, TheStereoThreadsPlanesAreTheDensifiersOwnFirstStep) {
  const synthetic::SceneConfig config = synthetic::preset("boxes", 640, 360);
  const synthetic::SceneRenderer scene(config);
  synthetic::StereoSample s;
  scene.render(2, s);
  PipelineParams params;
  params.stereo.max_disparity = synthetic::covering_max_disparity(config);
  params.stereo.internal_resolution = "half";
  const auto matcher = stereo::make_cpu_stereo_matcher(params.stereo);
  StereoSlot slot;
  prepare_frame(params.stereo, s.left.cview(), 0, slot);
  stereo_frame(*matcher, s.left.cview(), s.right.cview(), slot, true);
  densify::MatchPlaneSmoother planes;
  plane_frame(params.densify, planes, slot);
  ASSERT_TRUE(slot.planar.view().same_size(slot.sparse.view()));
  EXPECT_FALSE(same_bytes(slot.planar.cview(), slot.sparse.cview()));  // the planes moved matches

  // The result carries the planar map to the densify step, which then skips its own planes.
  const auto extractor = contour::make_cpu_contour_extractor(params.contour);
  DepthResult with, without;
  contour_frame(*extractor, slot, nullptr, nullptr, with);
  EXPECT_TRUE(same_bytes(with.planar.cview(), slot.planar.cview()));
  contour_frame(*extractor, slot, nullptr, nullptr, without);
  without.planes_done = false;
  densify::Densifier carried(params.densify), own(params.densify);
  densify_frame(carried, with);
  densify_frame(own, without);
  EXPECT_TRUE(same_bytes(with.dense.cview(), without.dense.cview()));
  EXPECT_GT(without.densify_timings.planes_ms, 0.0);
  EXPECT_EQ(with.densify_timings.planes_ms, slot.planes_ms);
  // ... and reads the map it is given: the unsmoothed matches give another dense map.
  DepthResult unsmoothed;
  contour_frame(*extractor, slot, nullptr, nullptr, unsmoothed);
  unsmoothed.planar.copy_from(slot.sparse.cview());
  densify::Densifier reads(params.densify);
  densify_frame(reads, unsmoothed);
  EXPECT_FALSE(same_bytes(unsmoothed.dense.cview(), without.dense.cview()));

  // Left to the densify step, the slot carries no planar map, and the densifier makes its own.
  plane_frame(params.densify, planes, slot, false);
  EXPECT_FALSE(slot.planes_done);
  DepthResult left_over;
  contour_frame(*extractor, slot, nullptr, nullptr, left_over);
  EXPECT_FALSE(left_over.planes_done);
  densify::Densifier later(params.densify);
  densify_frame(later, left_over);
  EXPECT_TRUE(same_bytes(left_over.dense.cview(), without.dense.cview()));

  // Without planes the step is a copy.
  params.densify.plane_window = 0;
  plane_frame(params.densify, planes, slot);
  EXPECT_TRUE(same_bytes(slot.planar.cview(), slot.sparse.cview()));

  // A planar map of another size is refused.
  Image<float> small(320, 180);
  densify::DensifyInputs in = densify_inputs(with, {});
  in.planar = small.cview();
  expect_refused(own, in, "planar");
}

TEST(ContourFrame, MovingTheMapsGivesTheCopysResultAndLeavesTheSlotItsSizes) {
  const synthetic::SceneConfig config = synthetic::preset("hand", 320, 180);
  const synthetic::SceneRenderer scene(config);
  PipelineParams params;
  params.stereo.max_disparity = synthetic::covering_max_disparity(config);
  params.stereo.internal_resolution = "half";
  const auto matcher = stereo::make_cpu_stereo_matcher(params.stereo);
  StereoSlot slots[3];
  densify::MatchPlaneSmoother planes;
  for (int i = 0; i < 3; ++i) {
    synthetic::StereoSample s;
    scene.render(i, s);
    prepare_frame(params.stereo, s.left.cview(), i, slots[i]);
    stereo_frame(*matcher, s.left.cview(), s.right.cview(), slots[i], true);
    plane_frame(params.densify, planes, slots[i]);
  }
  const auto extractor = contour::make_cpu_contour_extractor(params.contour);
  DepthResult copied;
  contour_frame(*extractor, slots[1], &slots[0], &slots[2], copied);
  // `moved` starts with maps of another size and content: the slot must not keep them.
  DepthResult moved;
  moved.image.resize(7, 5);
  moved.sparse.resize(3, 2);
  StereoSlot& centre = slots[1];
  contour_frame_moving_maps(*extractor, centre, &slots[0], &slots[2], moved);
  for (const DepthResult* r : {&copied, &moved}) {
    EXPECT_EQ(r->index, 1);
    EXPECT_TRUE(r->flow_cue);
    EXPECT_TRUE(r->planes_done);
  }
  EXPECT_TRUE(same_bytes(moved.image.cview(), copied.image.cview()));
  EXPECT_EQ(copied.right.width(), 320);
  EXPECT_TRUE(same_bytes(moved.right.cview(), copied.right.cview()));
  EXPECT_TRUE(centre.right.view().same_size(copied.right.view()));
  EXPECT_TRUE(same_bytes(moved.sparse.cview(), copied.sparse.cview()));
  EXPECT_TRUE(same_bytes(moved.planar.cview(), copied.planar.cview()));
  EXPECT_TRUE(same_bytes(moved.contours.cview(), copied.contours.cview()));
  EXPECT_TRUE(same_bytes(moved.m_fuse.cview(), copied.m_fuse.cview()));
  EXPECT_TRUE(centre.image.view().same_size(copied.image.view()));
  EXPECT_TRUE(centre.sparse.view().same_size(copied.sparse.view()));
  EXPECT_TRUE(centre.planar.view().same_size(copied.planar.view()));
  // Both results densify alike.
  densify::Densifier a(params.densify), b(params.densify);
  densify_frame(a, copied);
  densify_frame(b, moved);
  EXPECT_TRUE(same_bytes(moved.dense.cview(), copied.dense.cview()));
}

TEST(StereoFrame, KeepsTheRightImageForThePhotometricRefinementOnlyWhenAsked) {
  synthetic::SceneConfig config = synthetic::preset("boxes", 160, 96);
  config.color = true;
  const synthetic::SceneRenderer scene(config);
  synthetic::StereoSample s;
  scene.render(0, s);
  PipelineParams params;
  params.stereo.max_disparity = synthetic::covering_max_disparity(config);
  const auto matcher = stereo::make_cpu_stereo_matcher(params.stereo);
  StereoSlot slot;
  stereo_frame(*matcher, s.left.cview(), s.right.cview(), slot, true);
  ASSERT_EQ(slot.right.width(), 160);
  EXPECT_EQ(slot.right.channels(), 1);
  Image<std::uint8_t> scratch, expected;
  stereo::FalloffCorrection falloff;
  corrected_right_grey(s.right.cview(), slot.camera_correction, falloff, scratch, expected);
  EXPECT_TRUE(same_bytes(slot.right.cview(), expected.cview()));
  stereo_frame(*matcher, s.left.cview(), s.right.cview(), slot, false);
  EXPECT_TRUE(slot.right.view().empty());
  // The refinement reads it through the result: a densifier without it gives another map.
  DepthResult with, without;
  stereo_frame(*matcher, s.left.cview(), s.right.cview(), slot, true);
  prepare_frame(params.stereo, s.left.cview(), 0, slot);
  const auto extractor = contour::make_cpu_contour_extractor(params.contour);
  contour_frame(*extractor, slot, nullptr, nullptr, with);
  contour_frame(*extractor, slot, nullptr, nullptr, without);
  without.right.resize(0, 0);
  densify::Densifier a(params.densify), b(params.densify);
  densify_frame(a, with);
  densify_frame(b, without);
  EXPECT_FALSE(same_bytes(with.dense.cview(), without.dense.cview()));
  EXPECT_GT(with.densify_timings.refine_ms, 0.0);
  // ... and refuses one of another size.
  Image<std::uint8_t> small(80, 96);
  densify::DensifyInputs in = densify_inputs(with, {});
  in.right = small.cview();
  expect_refused(a, in, "the right image");
}

TEST(CorrectedRightGrey, TakesTheRowsLevelsAndFalloffOfTheCameraCorrection) {
  Image<std::uint8_t> right(64, 40);
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 64; ++x)
      right.view().row(y)[x] = static_cast<std::uint8_t>((x * 7 + y * 13) % 200 + 20);
  Image<std::uint8_t> scratch, out;
  stereo::FalloffCorrection falloff;
  stereo::CameraCorrection none;
  none.levels = stereo::no_exposure_map(1);
  corrected_right_grey(right.cview(), none, falloff, scratch, out);
  EXPECT_TRUE(same_bytes(out.cview(), right.cview()));

  stereo::CameraCorrection levels = none;
  levels.levels.channels[0] = {1.1, -3.0};
  corrected_right_grey(right.cview(), levels, falloff, scratch, out);
  stereo::ExposureTable table;
  table.build(levels.levels);
  Image<std::uint8_t> expected;
  table.apply(right.cview(), expected);
  EXPECT_TRUE(same_bytes(out.cview(), expected.cview()));

  stereo::CameraCorrection rows = none;
  rows.row_offset = 1.0;
  corrected_right_grey(right.cview(), rows, falloff, scratch, out);
  stereo::align_rows(right.cview(), {1.0, 0.0}, expected);
  EXPECT_TRUE(same_bytes(out.cview(), expected.cview()));

  // The lens fall-off last, on the grey: both views through the same table.
  stereo::CameraCorrection lens = levels;
  lens.falloff = 0.3;
  corrected_right_grey(right.cview(), lens, falloff, scratch, out);
  stereo::FalloffCorrection own;
  own.build(stereo::LensFalloff{0.3}, 64, 40, 1);
  Image<std::uint8_t> levelled;
  table.apply(right.cview(), levelled);
  own.apply(levelled.cview(), expected);
  EXPECT_TRUE(same_bytes(out.cview(), expected.cview()));
  EXPECT_GT(out.cview().row(0)[0], levelled.cview().row(0)[0]);      // a corner is brightened
  EXPECT_EQ(out.cview().row(20)[32], levelled.cview().row(20)[32]);  // the centre is not
  Image<std::uint8_t> left_out;
  corrected_left_grey(right.cview(), lens, falloff, scratch, left_out);
  own.apply(right.cview(), expected);
  EXPECT_TRUE(same_bytes(left_out.cview(), expected.cview()));
  corrected_left_grey(right.cview(), levels, falloff, scratch, left_out);
  EXPECT_TRUE(left_out.view().empty());  // no fall-off: the refinement reads the image itself

  // Colour: the channels' maps weighted as the grey weighs the channels.
  Image<std::uint8_t> colour(8, 4, 3);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 8; ++x) {
      std::uint8_t* p = colour.view().row(y) + 3 * x;
      p[0] = 100, p[1] = 100, p[2] = 100;
    }
  stereo::CameraCorrection colour_levels;
  colour_levels.levels = stereo::no_exposure_map(3);
  colour_levels.levels.channels[1] = {1.2, 0.0};  // green, 0.587 of the grey
  corrected_right_grey(colour.cview(), colour_levels, falloff, scratch, out);
  EXPECT_EQ(out.channels(), 1);
  EXPECT_NEAR(out.cview().row(2)[3], 100 * (1 + 0.2 * 0.587), 1.0);
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

TEST(ContourWindows, FramesPastTwoToTheThirtyOneKeepTheirNeighbours) {
  // 2^31 frames are 414 days at 60 fps: a service running that long must not wrap to frame -1.
  const FrameIndex t = FrameIndex{1} << 31;
  const ContourWindow centred = window_on_arrival(1, t);
  EXPECT_EQ(centred.centre, t - 1);
  EXPECT_EQ(centred.neighbour_a, t - 2);
  EXPECT_EQ(centred.neighbour_b, t);
  const ContourWindow causal = window_on_arrival(0, t + 1);
  EXPECT_EQ(causal.centre, t + 1);
  EXPECT_EQ(causal.neighbour_a, t);
  EXPECT_EQ(causal.neighbour_b, t - 1);
  EXPECT_EQ(window_at_end(t).neighbour_a, t - 1);
}

}  // namespace
}  // namespace dco::pipeline
