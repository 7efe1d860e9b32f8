#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>

#include "dco/core/error.hpp"
#include "dco/gpu/grid_stereo_matcher.hpp"
#include "dco/gpu/host_grid.hpp"
#include "stereo_cases.hpp"

namespace dco::gpu {
namespace {

using testing::StereoCase;

// Every output of the grid passes equals the CPU stage's, byte for byte.
void expect_same_as_cpu(const StereoCase& c) {
  testing::expect_same_as_cpu(
      c,
      [](const stereo::StereoParams& params) {
        return std::make_unique<GridStereoMatcher<HostGrid>>(params);
      },
      [](const std::string&, const stereo::StereoMatcher& grid, const stereo::StereoMatcher&) {
        // Not trivially equal: the checks kept a good share of the pixels and removed others.
        int kept = 0;
        const ImageView<const float> sparse = grid.internal_sparse_disparity();
        for (int y = 0; y < sparse.height; ++y)
          for (int x = 0; x < sparse.width; ++x) kept += std::isfinite(sparse.row(y)[x]) ? 1 : 0;
        EXPECT_GT(kept, sparse.width * sparse.height / 5);
        EXPECT_LT(kept, sparse.width * sparse.height);
      });
}

TEST(GridStereo, TsukubaIsTheCpuStageBitForBit) {
  expect_same_as_cpu(testing::real_pair("Tsukuba", "middlebury2001/Tsukuba/im3.png",
                                        "middlebury2001/Tsukuba/im4.png", 16));
}

TEST(GridStereo, TeddyIsTheCpuStageBitForBit) {
  expect_same_as_cpu(testing::real_pair("Teddy", "middlebury2003/Teddy/im2.png",
                                        "middlebury2003/Teddy/im6.png", 64));
}

TEST(GridStereo, HalfResolutionSyntheticFramesAreTheCpuStageBitForBit) {
  expect_same_as_cpu(testing::synthetic_pair("hand", 704, 396, /*color=*/true));
  expect_same_as_cpu(testing::synthetic_pair("boxes", 704, 396, /*color=*/false));
}

TEST(GridStereo, RejectsTheGuidedSearchWhichOnlyTheCpuStageHas) {
  stereo::StereoParams params;
  params.search_range = "guided";
  EXPECT_THROW(GridStereoMatcher<HostGrid>{params}, Error);
  params.search_range = "auto";
  EXPECT_NO_THROW(GridStereoMatcher<HostGrid>{params});
}

TEST(GridStereo, BadInputIsTheCpuStagesError) {
  GridStereoMatcher<HostGrid> grid(stereo::StereoParams{});
  Image<std::uint8_t> a(64, 32), b(63, 32);
  Image<float> out;
  try {
    grid.compute(a.cview(), b.cview(), out);
    FAIL() << "accepted a pair of two sizes";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("a rectified pair has one size"), std::string::npos);
  }
}

}  // namespace
}  // namespace dco::gpu
