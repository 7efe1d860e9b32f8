#pragma once

// A recording as dcod's replay:// source reads it (left/, right/, calib.toml), rendered from a
// synthetic scene, so tests know every frame's bytes.

#include <cstdio>
#include <filesystem>
#include <string>

#include "dco/core/calibration.hpp"
#include "dco/core/image_io.hpp"
#include "dco/core/synthetic_scene.hpp"

namespace dco::testing {

inline void write_synthetic_recording(const std::filesystem::path& dir, int frames, int width,
                                      int height, const std::string& scene = "hand") {
  synthetic::SceneRenderer renderer(synthetic::preset(scene, width, height));
  synthetic::StereoSample sample;
  std::filesystem::create_directories(dir / "left");
  std::filesystem::create_directories(dir / "right");
  for (int i = 0; i < frames; ++i) {
    renderer.render(i, sample);
    char name[32];
    std::snprintf(name, sizeof name, "%06d.png", i);
    save_image(dir / "left" / name, sample.left.cview());
    save_image(dir / "right" / name, sample.right.cview());
  }
  save_calibration(dir / "calib.toml", renderer.calibration());
}

}  // namespace dco::testing
