#pragma once

// Densifier inputs and solver settings on which the GPU solver must give the CPU solver's bytes.

#include <cmath>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "dco/core/synthetic_scene.hpp"
#include "dco/pipeline/densify/densifier.hpp"
#include "dco/pipeline/depth_pipeline.hpp"
#include "support/same_bytes.hpp"

namespace dco::gpu::testing {

// Two consecutive results of the CPU pipeline (sparse map, contours, cues, image and, where
// `photometric` refines the frame size, the corrected right image) of a moving synthetic scene:
// what the densifier is given for frames t and t+1.
inline std::vector<pipeline::DepthResult> densify_frames(
    const std::string& scene, int width, int height,
    const densify::PhotometricParams& photometric = {}) {
  const synthetic::SceneRenderer renderer(synthetic::preset(scene, width, height));
  pipeline::PipelineParams params;
  params.densify.photometric = photometric;
  params.stereo.max_disparity = synthetic::covering_max_disparity(renderer.config());
  pipeline::DepthPipeline cpu(params);
  std::vector<pipeline::DepthResult> frames;
  synthetic::StereoSample s;
  for (int i = 0; i < 3; ++i) {
    renderer.render(i, s);
    pipeline::DepthResult r;
    // Frames 1 and 2: the second with the causal window's flow cue.
    if (cpu.push(s.left.cview(), s.right.cview(), r) && r.index >= 1)
      frames.push_back(std::move(r));
  }
  return frames;
}

// The defaults, then one variant per branch of the solver.
inline std::vector<std::pair<std::string, densify::DensifyParams>> solver_variants() {
  std::vector<std::pair<std::string, densify::DensifyParams>> v{{"defaults", {}}};
  auto add = [&](const std::string& name, auto change) {
    densify::DensifyParams p;
    change(p);
    v.emplace_back(name, p);
  };
  add("full size", [](auto& p) { p.solve_resolution = "full"; });
  add("half size, sweeps only", [](auto& p) {
    p.solve_resolution = "half";
    p.fine_sweeps = 2;
    p.fine_iterations = 0;
  });
  add("half size, sweeps and the output's residual", [](auto& p) {
    p.solve_resolution = "half";
    p.fine_sweeps = 2;
    p.fine_iterations = 0;
    p.output_residual = true;
  });
  add("half size, sweeps and one iteration", [](auto& p) {
    p.solve_resolution = "half";
    p.fine_sweeps = 2;
    p.fine_iterations = 1;
  });
  add("half size, no refinement", [](auto& p) {
    p.solve_resolution = "half";
    p.fine_iterations = 0;
  });
  add("plain conjugate gradients", [](auto& p) {
    p.solve_resolution = "full";
    p.multigrid = false;
    p.max_iterations = 60;
  });
  add("tight tolerance", [](auto& p) { p.tolerance = 1e-6; });
  return v;
}

// The densifier with the solver make(params) against the CPU densifier under every variant, over
// both frames (the second warm-started from the first and pulled towards it): every output byte,
// the iterations and the residuals equal. Tolerance: none.
template <class Make, class Then>
void expect_same_dense_as_cpu(const std::vector<pipeline::DepthResult>& frames, const Make& make,
                              const Then& then) {
  using dco::testing::same_bytes;
  ASSERT_EQ(frames.size(), 2u);
  for (const auto& [variant, params] : solver_variants()) {
    SCOPED_TRACE(variant);
    densify::Densifier cpu(params), other(params, make);
    Image<float> expected, actual;
    for (const pipeline::DepthResult& f : frames) {
      const ImageView<const float> cpu_last = cpu.last_solution();
      const ImageView<const float> other_last = other.last_solution();
      cpu.compute(pipeline::densify_inputs(f, cpu_last), expected);
      other.compute(pipeline::densify_inputs(f, other_last), actual);
      EXPECT_TRUE(same_bytes(actual.cview(), expected.cview()));
      EXPECT_EQ(other.last_report().iterations, cpu.last_report().iterations);
      EXPECT_EQ(other.last_report().fine_iterations, cpu.last_report().fine_iterations);
      EXPECT_EQ(other.last_report().final_residual, cpu.last_report().final_residual);
      const double other_output = other.last_report().output_residual;
      const double cpu_output = cpu.last_report().output_residual;
      EXPECT_TRUE(std::isnan(cpu_output) ? std::isnan(other_output) : other_output == cpu_output)
          << other_output << " against " << cpu_output;
      EXPECT_EQ(other.last_report().converged, cpu.last_report().converged);
    }
    then(variant, cpu, other);
  }
}

}  // namespace dco::gpu::testing
