#include <gtest/gtest.h>

#include <memory>

#include "dco/gpu/grid_system_solver.hpp"
#include "dco/gpu/host_grid.hpp"
#include "densify_cases.hpp"

namespace dco::gpu {
namespace {

void expect_host_grid_is_cpu(const std::vector<pipeline::DepthResult>& frames) {
  testing::expect_same_dense_as_cpu(
      frames,
      [](const densify::DensifyParams& p) {
        return std::make_unique<GridSystemSolver<HostGrid>>(p);
      },
      [](const std::string& variant, const densify::Densifier& cpu, const densify::Densifier&) {
        // Not trivially equal: the solver iterated.
        (void)variant;
        EXPECT_GT(cpu.last_report().iterations, 0);
      });
}

TEST(GridDensify, SmallFramesAreTheCpuSolverBitForBit) {
  expect_host_grid_is_cpu(testing::densify_frames("hand", 320, 180));
}

TEST(GridDensify, HalfSizeSolvesOfWideFramesAreTheCpuSolverBitForBit) {
  expect_host_grid_is_cpu(testing::densify_frames("boxes", 704, 396));
}

}  // namespace
}  // namespace dco::gpu
