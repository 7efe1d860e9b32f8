#pragma once

#include <cstdint>
#include <filesystem>

#include "dco/core/image.hpp"

namespace dco::tools {

// Pictures a person looks at to judge a depth map, written as PNG.

// Disparity in false colour (near = red, far = blue), black where unknown.
void write_disparity_colour(const std::filesystem::path& path, ImageView<const float> disparity,
                            float max_disparity);

// The image with depth contours painted red.
void write_contour_overlay(const std::filesystem::path& path, ImageView<const std::uint8_t> image,
                           ImageView<const std::uint8_t> contours);

// A virtual fronto-parallel plane at `plane_disparity` composited into the image the way a
// renderer with per-pixel occlusion would: a blue checkerboard where the plane is in front of
// the real scene, the camera image where a real object is closer and hides it.
void write_occlusion_composite(const std::filesystem::path& path,
                               ImageView<const std::uint8_t> image,
                               ImageView<const float> disparity, float plane_disparity);

}  // namespace dco::tools
