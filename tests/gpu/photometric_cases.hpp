#pragma once

// Inputs and settings on which a grid's photometric refinement must give the CPU refiner's bytes.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "dco/core/image.hpp"
#include "dco/pipeline/densify/densifier.hpp"
#include "dco/pipeline/densify/photometric_refiner.hpp"
#include "dco/pipeline/depth_pipeline.hpp"
#include "support/same_bytes.hpp"

namespace dco::gpu::testing {

// The defaults, then one variant per branch of the refinement; every frame size refined.
inline std::vector<std::pair<std::string, densify::PhotometricParams>> photometric_variants() {
  std::vector<std::pair<std::string, densify::PhotometricParams>> v;
  auto add = [&](const std::string& name, auto change) {
    densify::PhotometricParams p;
    p.max_pixels = 100000000;
    change(p);
    v.emplace_back(name, p);
  };
  add("defaults", [](auto&) {});
  add("one sweep, three iterations", [](auto& p) {
    p.sweeps = 1;
    p.iterations = 3;
  });
  add("grey levels only", [](auto& p) { p.gamma = 0; });
  add("gradients only, no smoothness", [](auto& p) {
    p.delta = 0;
    p.alpha = 0;
  });
  return v;
}

// The densifier with the refinement make() against the CPU densifier under every variant, over
// both frames: every output byte equal (tolerance: none), and the refinement changed the map.
template <class Make, class Then>
void expect_same_refinement_as_cpu(const std::vector<pipeline::DepthResult>& frames,
                                   const Make& make, const Then& then) {
  using dco::testing::same_bytes;
  ASSERT_EQ(frames.size(), 2u);
  for (const auto& [variant, photometric] : photometric_variants()) {
    SCOPED_TRACE(variant);
    densify::DensifyParams params, unrefined;
    params.photometric = photometric;
    unrefined.photometric.iterations = 0;
    densify::Densifier cpu(params), other(params, {}, make), plain(unrefined);
    Image<float> expected, actual, before;
    for (const pipeline::DepthResult& f : frames) {
      ASSERT_FALSE(f.right.empty());
      cpu.compute(pipeline::densify_inputs(f, cpu.last_solution()), expected);
      other.compute(pipeline::densify_inputs(f, other.last_solution()), actual);
      plain.compute(pipeline::densify_inputs(f, plain.last_solution()), before);
      EXPECT_TRUE(same_bytes(actual.cview(), expected.cview()));
      EXPECT_FALSE(same_bytes(before.cview(), expected.cview()));
    }
    then(variant, cpu, other);
  }
}

// The refinement alone on small textured pairs of odd sizes, from a start with values below 0
// near the left edge (the clamp at the end) and a step: the CPU refiner's bytes.
template <class Make>
void expect_same_maps_as_cpu_refiner(const Make& make) {
  using dco::testing::same_bytes;
  const auto texture = [](double x, double y) {
    return static_cast<std::uint8_t>(std::lround(
        std::clamp(128 + 50 * std::sin(0.37 * x + 0.11 * y) + 40 * std::sin(0.23 * y - 0.19 * x),
                   0.0, 255.0)));
  };
  const auto truth = [](int x, int y) { return 0.03 * x + ((x > 20 && y > 6) ? 4.0 : 0.0); };
  for (const auto& [w, h] :
       {std::pair{1, 1}, std::pair{2, 3}, std::pair{7, 9}, std::pair{33, 25}, std::pair{64, 17}}) {
    SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h));
    Image<std::uint8_t> left(w, h), right(w, h);
    Image<float> start(w, h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        left.view().row(y)[x] = texture(x, y);
        right.view().row(y)[x] = texture(x + truth(x, y), y);
        start.view().row(y)[x] = static_cast<float>(truth(x, y)) - 0.4f * ((x + 2 * y) % 3 == 0);
      }
    for (const auto& [variant, params] : photometric_variants()) {
      SCOPED_TRACE(variant);
      Image<float> expected(w, h), actual(w, h);
      expected.copy_from(start.cview());
      actual.copy_from(start.cview());
      densify::PhotometricRefiner cpu;
      const std::unique_ptr<densify::PhotometricRefinement> other = make();
      cpu.refine(left.cview(), right.cview(), params, expected.view());
      other->refine(left.cview(), right.cview(), params, actual.view());
      EXPECT_TRUE(same_bytes(actual.cview(), expected.cview()));
    }
  }
}

}  // namespace dco::gpu::testing
