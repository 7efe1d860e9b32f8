#pragma once

// Stereo pairs and stage settings on which the GPU stage must give the CPU stage's bytes.

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dco/core/image.hpp"
#include "dco/core/image_io.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"
#include "dco/pipeline/stereo/stereo_params.hpp"
#include "support/same_bytes.hpp"

namespace dco::gpu::testing {

struct StereoCase {
  std::string name;
  Image<std::uint8_t> left, right;
  stereo::StereoParams params;
};

inline std::filesystem::path data_dir() {
  return DCO_DATA_DIR;
}

// A real pair from the shared data.
inline StereoCase real_pair(const std::string& name, const std::string& left,
                            const std::string& right, int max_disparity) {
  StereoCase c;
  c.name = name;
  c.left = load_image(data_dir() / left);
  c.right = load_image(data_dir() / right);
  c.params.max_disparity = max_disparity;
  return c;
}

// A synthetic frame wider than 640 px: the half-resolution internal path.
inline StereoCase synthetic_pair(const std::string& scene, int width, int height, bool color) {
  synthetic::SceneConfig config = synthetic::preset(scene, width, height);
  config.color = color;
  const synthetic::SceneRenderer renderer(config);
  synthetic::StereoSample sample;
  renderer.render(3, sample);
  StereoCase c;
  c.name = scene + (color ? " colour" : " grey");
  c.left = std::move(sample.left);
  c.right = std::move(sample.right);
  c.params.max_disparity = synthetic::covering_max_disparity(config);
  return c;
}

// The defaults, then one variant per branch of the stage.
inline std::vector<std::pair<std::string, stereo::StereoParams>> variants(
    const stereo::StereoParams& base) {
  std::vector<std::pair<std::string, stereo::StereoParams>> v{{"defaults", base}};
  auto add = [&](const std::string& name, auto change) {
    stereo::StereoParams p = base;
    change(p);
    v.emplace_back(name, p);
  };
  add("two aggregation passes", [](auto& p) { p.aggregation_passes = 2; });
  add("three passes, no smoothing", [](auto& p) {
    p.aggregation_passes = 3;
    p.smooth_arms = false;
  });
  add("votes fill, two iterations", [](auto& p) {
    p.vote_fill = true;
    p.vote_iterations = 2;
  });
  add("no checks but left-right", [](auto& p) {
    p.uniqueness = 0;
    p.vote_iterations = 0;
    p.max_neighbour_jump = -1;
    p.speckle_size = 0;
    p.subpixel = false;
  });
  add("grey cost", [](auto& p) { p.use_color = false; });
  add("small census, short arms", [](auto& p) {
    p.census_width = 5;
    p.census_height = 5;
    p.arm_max = 12;
    p.arm_short = 6;
  });
  return v;
}

// Runs the stage make(params) and the CPU stage on the case under every variant, two frames each
// (the second reuses every buffer of the first), and expects every output byte equal: the map at
// input size, the internal raw and sparse maps and the internal grey image. Tolerance: none; the
// stage computes the CPU's integer costs, sums and decisions and the same IEEE float operations.
// then(variant, stage, cpu) runs after each comparison.
template <class Make, class Then>
void expect_same_as_cpu(const StereoCase& c, const Make& make, const Then& then) {
  using dco::testing::same_bytes;
  for (const auto& [variant, params] : variants(c.params)) {
    SCOPED_TRACE(c.name + ", " + variant);
    // The grid stage searches every disparity ("auto" is "full" there); so does the reference.
    stereo::StereoParams full = params;
    full.search_range = "full";
    const auto cpu = stereo::make_cpu_stereo_matcher(full);
    const std::unique_ptr<stereo::StereoMatcher> stage = make(params);
    Image<float> expected, actual;
    for (int frame = 0; frame < 2; ++frame) {
      cpu->compute(c.left.cview(), c.right.cview(), expected);
      stage->compute(c.left.cview(), c.right.cview(), actual);
    }
    EXPECT_EQ(stage->last_scale(), cpu->last_scale());
    EXPECT_TRUE(same_bytes(actual.cview(), expected.cview()));
    EXPECT_TRUE(same_bytes(stage->internal_raw_disparity(), cpu->internal_raw_disparity()));
    EXPECT_TRUE(same_bytes(stage->internal_sparse_disparity(), cpu->internal_sparse_disparity()));
    EXPECT_TRUE(same_bytes(stage->internal_left_gray(), cpu->internal_left_gray()));
    then(variant, *stage, *cpu);
  }
}

}  // namespace dco::gpu::testing
