#include <gtest/gtest.h>

#include <memory>

#include "contour_cases.hpp"
#include "dco/core/error.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/gpu/grid_contour_extractor.hpp"
#include "dco/gpu/grid_stereo_matcher.hpp"
#include "dco/gpu/grid_system_solver.hpp"
#include "dco/gpu/host_grid.hpp"
#include "dco/pipeline/depth_pipeline.hpp"
#include "support/same_bytes.hpp"

namespace dco::gpu {
namespace {

auto host_grid_stage() {
  return [](const contour::ContourParams& params) {
    return std::make_unique<GridContourExtractor<HostGrid>>(params);
  };
}

TEST(GridContour, TsukubaIsTheCpuStageBitForBit) {
  testing::expect_same_contours_as_cpu(
      testing::real_contour_case(testing::real_pair("Tsukuba", "middlebury2001/Tsukuba/im3.png",
                                                    "middlebury2001/Tsukuba/im4.png", 16)),
      host_grid_stage());
}

TEST(GridContour, MovingSyntheticHandIsTheCpuStageBitForBit) {
  testing::expect_same_contours_as_cpu(testing::synthetic_contour_case("hand"), host_grid_stage());
}

TEST(GridContour, BadInputGetsTheCpuStagesError) {
  const testing::ContourCase c = testing::real_contour_case(testing::real_pair(
      "Tsukuba", "middlebury2001/Tsukuba/im3.png", "middlebury2001/Tsukuba/im4.png", 16));
  GridContourExtractor<HostGrid> stage{contour::ContourParams{}};
  const auto cpu = contour::make_cpu_contour_extractor({});
  contour::ContourOutputs out;
  contour::ContourInputs in = c.inputs(false);
  in.disparity = ImageView<const float>(c.disparity.cview().data, c.disparity.width() - 1,
                                        c.disparity.height(), 1, c.disparity.cview().stride);
  std::string expected;
  try {
    cpu->compute(in, out);
  } catch (const Error& e) {
    expected = e.what();
  }
  ASSERT_NE(expected, "");
  try {
    stage.compute(in, out);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), expected);
  }
}

// The whole offline pipeline with every grid stage (as the CUDA backend wires them) gives the CPU
// pipeline's dense depth, frame for frame.
TEST(GridStages, DepthPipelineWithGridStagesIsTheCpuPipelineBitForBit) {
  const synthetic::SceneRenderer scene(synthetic::preset("hand", 704, 396));
  pipeline::PipelineParams params;
  params.stereo.max_disparity = synthetic::covering_max_disparity(scene.config());
  params.stereo.search_range = "full";  // what "auto" means on the grid
  pipeline::StageFactories grid;
  grid.stereo = [](const stereo::StereoParams& p) {
    return std::make_unique<GridStereoMatcher<HostGrid>>(p);
  };
  grid.contour = [](const contour::ContourParams& p) {
    return std::make_unique<GridContourExtractor<HostGrid>>(p);
  };
  grid.densify_solver = [](const densify::DensifyParams& p) {
    return std::make_unique<GridSystemSolver<HostGrid>>(p);
  };
  pipeline::DepthPipeline cpu(params), on_grid(params, grid);
  synthetic::StereoSample s;
  pipeline::DepthResult expected, actual;
  int compared = 0;
  for (int i = 0; i < 4; ++i) {
    scene.render(i, s);
    const bool a = cpu.push(s.left.cview(), s.right.cview(), expected);
    const bool b = on_grid.push(s.left.cview(), s.right.cview(), actual);
    ASSERT_EQ(a, b);
    if (!a) continue;
    SCOPED_TRACE("frame " + std::to_string(expected.index));
    EXPECT_TRUE(dco::testing::same_bytes(actual.dense, expected.dense));
    EXPECT_TRUE(dco::testing::same_bytes(actual.contours, expected.contours));
    ++compared;
  }
  EXPECT_EQ(compared, 4);  // the causal window gives every frame at once
}

}  // namespace
}  // namespace dco::gpu
