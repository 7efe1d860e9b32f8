#pragma once

#include <filesystem>

#include "dco/core/image.hpp"

namespace dco {

// PFM ("Pf" one channel, "PF" three channels), the format of Middlebury and SceneFlow ground truth.
// Rows are stored bottom-to-top; the sign of the scale gives the byte order. read_pfm returns the
// image top-to-bottom in host order; non-finite values (+inf = unknown) are kept as they are.
Image<float> read_pfm(const std::filesystem::path& path);
// Writes little-endian "Pf" (channels == 1) or "PF" (channels == 3).
void write_pfm(const std::filesystem::path& path, ImageView<const float> image);

// 16-bit PNG disparity in the KITTI convention: value = round(d * 256), 0 = unknown.
// Disparities that are not finite or not positive are written as 0; values above 255.99 clamp.
void write_disparity_png16(const std::filesystem::path& path, ImageView<const float> disparity);
// Returns disparity in pixels with +inf where the file has 0.
Image<float> read_disparity_png16(const std::filesystem::path& path);

// 16-bit PNG depth in millimetres, 0 = unknown (the convention of RGB-D datasets and ROS).
// Depth in metres; non-finite or non-positive values become 0, values above 65.535 m clamp.
void write_depth_png16(const std::filesystem::path& path, ImageView<const float> depth_m);
// Returns metres with +inf where the file has 0.
Image<float> read_depth_png16(const std::filesystem::path& path);

}  // namespace dco
