#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <memory>
#include <vector>

#include "dco/gpu/grid_system_solver.hpp"
#include "dco/gpu/host_grid.hpp"
#include "dco/pipeline/densify/multigrid.hpp"
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

// The coarsest level's sweeps as launch_steps steps (SmoothColours) against the CPU's red-black
// sweeps (densify::gauss_seidel) on a system with odd sides and uneven weights, a few sweeps from
// zero so every step shows in the result.
TEST(GridDensify, SweepStepsAreTheCpuRedBlackSweeps) {
  const int w = 23, h = 13;
  std::uint32_t state = 12345;
  auto uniform = [&state](float lo, float hi) {
    state = state * 1664525u + 1013904223u;
    return lo + (hi - lo) * static_cast<float>(state >> 8) / static_cast<float>(1u << 24);
  };
  densify::GridSystem a;
  a.resize(w, h);
  Image<float> b(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      a.data.row(y)[x] = uniform(0.05f, 1.0f);
      a.wx.row(y)[x] = uniform(0.0f, 2.0f);
      a.wy.row(y)[x] = uniform(0.0f, 2.0f);
      b.row(y)[x] = uniform(-1.0f, 1.0f);
    }
  a.update_diagonal();
  auto tight = [w, h](const Image<float>& im) {
    std::vector<float> v(static_cast<std::size_t>(w) * h);
    for (int y = 0; y < h; ++y) std::memcpy(v.data() + y * w, im.row(y), w * sizeof(float));
    return v;
  };
  std::vector<float> data = tight(a.data), wx = tight(a.wx), wy = tight(a.wy), diag = tight(a.diag),
                     inv_diag = tight(a.inv_diag), tb = tight(b);
  const passes::SystemView view{data.data(),     wx.data(), wy.data(), diag.data(),
                                inv_diag.data(), w,         h};
  for (const bool red_first : {true, false})
    for (const int sweeps : {1, 3}) {
      SCOPED_TRACE(std::to_string(sweeps) + (red_first ? " red first" : " black first"));
      Image<float> expected(w, h);
      expected.fill(0.0f);
      densify::SweepRows rows;
      densify::gauss_seidel(a, b.cview(), expected.view(), sweeps, red_first, rows);
      auto run = [&](int steps) {
        std::vector<float> x(static_cast<std::size_t>(w) * h, 0.0f);
        HostGrid grid;
        grid.launch_steps(w, h, steps,
                          passes::SmoothColours{view, tb.data(), x.data(), red_first ? 0 : 1});
        return x;
      };
      const std::vector<float> x = run(2 * sweeps);
      EXPECT_TRUE(
          dco::testing::same_bytes(ImageView<const float>(x.data(), w, h, 1, w), expected.cview()));
      // One step short is not the same: the comparison sees each step.
      const std::vector<float> short_by_one = run(2 * sweeps - 1);
      EXPECT_FALSE(dco::testing::same_bytes(ImageView<const float>(short_by_one.data(), w, h, 1, w),
                                            expected.cview()));
    }
}

}  // namespace
}  // namespace dco::gpu
