#pragma once

#include <cstdint>
#include <vector>

#include "dco/indemind/calibration_blob.hpp"

namespace dco::testing {

// Renders the simulated module's side-by-side raw frame (2·width × height grey, left half first):
// a textured box at `box_depth_m` in front of a textured wall at `wall_depth_m`, seen through each
// camera's Kannala-Brandt model (intrinsics scaled from the calibration to width × height).
std::vector<std::uint8_t> render_side_by_side(const indemind::ModuleCalibration& calibration,
                                              int width, int height, double box_depth_m,
                                              double wall_depth_m);

}  // namespace dco::testing
