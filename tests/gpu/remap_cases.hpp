#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <random>
#include <string>

#include "dco/core/image.hpp"
#include "dco/core/rectifier.hpp"
#include "dco/core/stopwatch.hpp"
#include "support/example_rigs.hpp"
#include "support/same_bytes.hpp"

// Rectification cases shared by the host-grid and CUDA tests: both example rigs, grey and colour,
// through a remapper against Rectifier's cv::remap.
namespace dco::gpu::testing {

// Texture with edges and smooth ramps, so every interpolation weight matters.
inline Image<std::uint8_t> raw_image(int width, int height, int channels, unsigned seed) {
  Image<std::uint8_t> img(width, height, channels);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> noise(0, 255);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < channels; ++c) {
        const int ramp = (x * 3 + y * 2 + c * 40) % 256;
        img.at(x, y, c) = static_cast<std::uint8_t>(((x / 8 + y / 8) % 2) ? noise(rng) : ramp);
      }
  return img;
}

using RemapperFactory = std::function<std::unique_ptr<PairRemapper>(const Rectifier&)>;

// Each rig in grey and colour, two frames each: the remapper's pair equals the CPU's, byte for
// byte. `report` gets the case's name and both times.
inline void expect_rigs_rectify_as_cpu(
    const RemapperFactory& make,
    const std::function<void(const std::string&, double cpu_ms, double other_ms)>& report = {}) {
  for (const StereoCalibration& calib : {test::pinhole_rig(), test::kannala_brandt_rig()}) {
    const Rectifier rectifier(calib);
    ASSERT_TRUE(rectifier.needs_remap());
    const std::unique_ptr<PairRemapper> remapper = make(rectifier);
    for (int channels : {1, 3}) {
      Image<std::uint8_t> cpu_l, cpu_r, out_l, out_r;
      for (unsigned frame = 0; frame < 2; ++frame) {
        const auto l = raw_image(calib.left.width, calib.left.height, channels, 10 + frame);
        const auto r = raw_image(calib.left.width, calib.left.height, channels, 20 + frame);
        Stopwatch t;
        rectifier.rectify(l.cview(), r.cview(), cpu_l, cpu_r);
        const double cpu_ms = t.lap_ms();
        rectifier.rectify(l.cview(), r.cview(), out_l, out_r, remapper.get());
        const double other_ms = t.lap_ms();
        const std::string name = calib.source + (channels == 3 ? ", colour" : ", grey");
        EXPECT_TRUE(dco::testing::same_bytes(cpu_l, out_l)) << name << " left";
        EXPECT_TRUE(dco::testing::same_bytes(cpu_r, out_r)) << name << " right";
        if (report) report(name, cpu_ms, other_ms);
      }
    }
  }
}

}  // namespace dco::gpu::testing
