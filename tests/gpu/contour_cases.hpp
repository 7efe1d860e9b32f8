#pragma once

// Contour-stage inputs and settings on which the GPU stage must give the CPU stage's bytes.

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "dco/core/image.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/pipeline/contour/contour_extractor.hpp"
#include "dco/pipeline/contour/gated_canny.hpp"
#include "dco/pipeline/contour/stereo_cue.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"
#include "stereo_cases.hpp"
#include "support/same_bytes.hpp"

namespace dco::gpu::testing {

// The inputs the pipeline hands the contour stage, made by the CPU stereo stage: the grey frame
// at input size, the internal grey frames t-1, t, t+1 and the internal WTA disparity of t.
struct ContourCase {
  std::string name;
  Image<std::uint8_t> image, centre, before, after;
  Image<float> disparity;

  contour::ContourInputs inputs(bool neighbours) const {
    contour::ContourInputs in;
    in.image = image.cview();
    in.centre = centre.cview();
    if (neighbours) {
      in.neighbour_a = before.cview();
      in.neighbour_b = after.cview();
    }
    in.disparity = disparity.cview();
    return in;
  }
};

template <class T>
Image<T> copy_of(ImageView<const T> v) {
  Image<T> out(v.width, v.height, v.channels);
  for (int y = 0; y < v.height; ++y)
    std::copy(v.row(y), v.row(y) + static_cast<std::ptrdiff_t>(v.width) * v.channels, out.row(y));
  return out;
}

// A real grey-converted pair: internal resolution equals the input (narrower than 640 px), no
// neighbours.
inline ContourCase real_contour_case(const StereoCase& pair) {
  const auto stage = stereo::make_cpu_stereo_matcher(pair.params);
  Image<float> full;
  stage->compute(pair.left.cview(), pair.right.cview(), full);
  ContourCase c;
  c.name = pair.name;
  c.centre = copy_of(stage->internal_left_gray());
  c.image = copy_of(c.centre.cview());
  c.disparity = copy_of(stage->internal_raw_disparity());
  return c;
}

// Three frames of a moving synthetic grey scene at 1280x720: half-resolution internal frames,
// DIS flow between them.
inline ContourCase synthetic_contour_case(const std::string& scene) {
  synthetic::SceneConfig config = synthetic::preset(scene, 1280, 720);
  const synthetic::SceneRenderer renderer(config);
  stereo::StereoParams params;
  params.max_disparity = synthetic::covering_max_disparity(config);
  const auto stage = stereo::make_cpu_stereo_matcher(params);
  ContourCase c;
  c.name = scene + " 1280x720";
  Image<float> full;
  for (int frame : {4, 6, 5}) {  // t-1, t+1, then t last so the stage holds t's maps
    synthetic::StereoSample sample;
    renderer.render(frame, sample);
    stage->compute(sample.left.cview(), sample.right.cview(), full);
    Image<std::uint8_t> grey = copy_of(stage->internal_left_gray());
    if (frame == 4) c.before = std::move(grey);
    if (frame == 6) c.after = std::move(grey);
    if (frame == 5) {
      c.centre = std::move(grey);
      c.image = std::move(sample.left);
    }
  }
  c.disparity = copy_of(stage->internal_raw_disparity());
  return c;
}

// The defaults, then one variant per branch of the stage.
inline std::vector<std::pair<std::string, contour::ContourParams>> contour_variants() {
  std::vector<std::pair<std::string, contour::ContourParams>> v{{"defaults", {}}};
  auto add = [&](const std::string& name, auto change) {
    contour::ContourParams p;
    change(p);
    v.emplace_back(name, p);
  };
  add("flow cue only", [](auto& p) { p.use_stereo = false; });
  add("stereo cue only", [](auto& p) { p.use_flow = false; });
  add("no cue", [](auto& p) {
    p.use_flow = false;
    p.use_stereo = false;
  });
  add("small box, steep jumps", [](auto& p) {
    p.box_size = 5;
    p.stereo_jump = 1.0;
  });
  add("open gate, low thresholds", [](auto& p) {
    p.t_depth = 0.0;
    p.t_low = 0.01;
    p.t_high = 0.03;
  });
  return v;
}

// Runs the stage make(params) and the CPU stage under every variant, two frames each (the second
// reuses every buffer of the first), with and without the neighbour frames, and expects every
// output byte equal: M_fuse, M_I and the contour map. Tolerance: none.
template <class Make>
void expect_same_contours_as_cpu(const ContourCase& c, const Make& make) {
  using dco::testing::same_bytes;
  for (const bool neighbours : {true, false}) {
    if (neighbours && c.before.empty()) continue;
    for (const auto& [variant, params] : contour_variants()) {
      SCOPED_TRACE(c.name + ", " + variant + (neighbours ? ", three frames" : ", one frame"));
      const auto cpu = contour::make_cpu_contour_extractor(params);
      const std::unique_ptr<contour::ContourExtractor> stage = make(params);
      contour::ContourOutputs expected, actual;
      for (int frame = 0; frame < 2; ++frame) {
        cpu->compute(c.inputs(neighbours), expected);
        stage->compute(c.inputs(neighbours), actual);
      }
      EXPECT_TRUE(same_bytes(actual.m_fuse, expected.m_fuse));
      EXPECT_TRUE(same_bytes(actual.m_intensity, expected.m_intensity));
      EXPECT_TRUE(same_bytes(actual.contours, expected.contours));
      // With the image's gradients and the stereo cue made by the caller: the same contours, and
      // M_I left to it.
      contour::ContourInputs given = c.inputs(neighbours);
      contour::GradientScratch scratch;
      Image<float> m_intensity, cue;
      Image<std::uint8_t> direction;
      contour::intensity_gradients(given.image, scratch, m_intensity, direction);
      EXPECT_TRUE(same_bytes(m_intensity, expected.m_intensity));
      given.m_intensity = m_intensity.cview();
      given.direction = direction.cview();
      if (!given.disparity.empty()) {
        contour::StereoCueScratch cue_scratch;
        contour::stereo_cue(given.disparity, static_cast<float>(params.stereo_jump),
                            params.box_size, cue_scratch, cue);
        given.stereo_cue = cue.cview();
      }
      contour::ContourOutputs by_cpu, by_stage;
      cpu->compute(given, by_cpu);
      stage->compute(given, by_stage);
      for (const contour::ContourOutputs* o : {&by_cpu, &by_stage}) {
        EXPECT_TRUE(same_bytes(o->m_fuse, expected.m_fuse));
        EXPECT_TRUE(same_bytes(o->contours, expected.contours));
        EXPECT_TRUE(o->m_intensity.empty());
      }
      if (neighbours && params.use_flow) {
        // The flow cue made ahead (as the runtime does with lookahead 0) and handed back: the
        // same cue from both stages, and the same outputs.
        Image<float> cpu_cue, stage_cue;
        contour::ContourTimings cpu_times, stage_times;
        cpu->flow_cue(given, cpu_cue, cpu_times);
        stage->flow_cue(given, stage_cue, stage_times);
        EXPECT_TRUE(same_bytes(stage_cue, cpu_cue));
        EXPECT_EQ(stage_times.dis_fields, 2);
        given.flow_cue = stage_cue.cview();
        cpu->compute(given, by_cpu);
        stage->compute(given, by_stage);
        for (const contour::ContourOutputs* o : {&by_cpu, &by_stage}) {
          EXPECT_TRUE(same_bytes(o->m_fuse, expected.m_fuse));
          EXPECT_TRUE(same_bytes(o->contours, expected.contours));
        }
        EXPECT_EQ(stage->last_timings().dis_fields, 0);
      }
      if (variant == "defaults") {
        // Not trivially equal: contours were found, and not everywhere.
        long on = 0;
        for (int y = 0; y < actual.contours.height(); ++y)
          for (int x = 0; x < actual.contours.width(); ++x) on += actual.contours.row(y)[x] != 0;
        EXPECT_GT(on, 100);
        EXPECT_LT(on, static_cast<long>(actual.contours.width()) * actual.contours.height() / 4);
      }
    }
  }
}

}  // namespace dco::gpu::testing
