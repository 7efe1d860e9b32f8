#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "dco/core/error.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/gpu/grid_photometric_refiner.hpp"
#include "dco/gpu/host_grid.hpp"
#include "dco/pipeline/depth_pipeline.hpp"
#include "densify_cases.hpp"
#include "photometric_cases.hpp"

namespace dco::gpu {
namespace {

std::unique_ptr<densify::PhotometricRefinement> host_grid_refiner() {
  return std::make_unique<GridPhotometricRefiner<HostGrid>>();
}

TEST(GridPhotometric, DenseFramesAreTheCpuRefinementBitForBit) {
  densify::PhotometricParams photometric;
  testing::expect_same_refinement_as_cpu(
      testing::densify_frames("hand", 320, 180, photometric), host_grid_refiner,
      [](const std::string&, const densify::Densifier&, const densify::Densifier&) {});
}

TEST(GridPhotometric, OddSizesAndValuesBelowZeroAreTheCpuRefinersBits) {
  testing::expect_same_maps_as_cpu_refiner(host_grid_refiner);
}

// photometric_max_pixels is the CPU's time budget: a grid refinement refines larger frames too,
// the pipeline keeps their right image for it, and they come out as the CPU gives them where its
// budget covers them.
TEST(GridPhotometric, RefinesFramesOverTheCpusPixelBudgetAsTheCpuWould) {
  const synthetic::SceneRenderer renderer(synthetic::preset("hand", 320, 180));
  pipeline::PipelineParams over_budget;
  over_budget.stereo.max_disparity = synthetic::covering_max_disparity(renderer.config());
  over_budget.densify.photometric.max_pixels = 320 * 180 - 1;
  pipeline::PipelineParams within_budget = over_budget;
  within_budget.densify.photometric.max_pixels = 320 * 180;
  pipeline::StageFactories grid;
  grid.photometric_refinement = host_grid_refiner;
  pipeline::DepthPipeline cpu_skips(over_budget), cpu_refines(within_budget),
      grid_refines(over_budget, grid);
  synthetic::StereoSample s;
  int compared = 0;
  for (int i = 0; i < 4; ++i) {
    renderer.render(i, s);
    pipeline::DepthResult skipped, expected, actual;
    const bool out = cpu_skips.push(s.left.cview(), s.right.cview(), skipped);
    ASSERT_EQ(cpu_refines.push(s.left.cview(), s.right.cview(), expected), out);
    ASSERT_EQ(grid_refines.push(s.left.cview(), s.right.cview(), actual), out);
    if (!out) continue;
    EXPECT_TRUE(skipped.right.empty());
    EXPECT_FALSE(actual.right.empty());
    EXPECT_TRUE(dco::testing::same_bytes(actual.dense.cview(), expected.dense.cview()));
    EXPECT_FALSE(dco::testing::same_bytes(skipped.dense.cview(), expected.dense.cview()));
    ++compared;
  }
  EXPECT_EQ(compared, 4);  // the causal window gives every frame at once
}

TEST(GridPhotometric, RefusesImagesOfAnotherSize) {
  Image<std::uint8_t> left(16, 8), right(15, 8);
  Image<float> d(16, 8);
  GridPhotometricRefiner<HostGrid> refiner;
  EXPECT_THROW(refiner.refine(left.cview(), right.cview(), densify::PhotometricParams{}, d.view()),
               Error);
}

}  // namespace
}  // namespace dco::gpu
