#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "dco/client.hpp"

// What a renderer does with a depth frame, as a picture: the camera image (or, without one, the
// depth as grey) with a virtual box at a fixed distance over the middle of the view, drawn only
// where no real surface is nearer. `rgb` receives width * height * 3 bytes.
void render_occlusion_overlay(const dco::client::FrameView& frame, double virtual_depth_m,
                              std::vector<std::uint8_t>& rgb);

// Writes a binary PPM atomically (a temporary file, then rename). Returns false with the reason.
bool write_ppm(const std::string& path, const std::vector<std::uint8_t>& rgb, std::uint32_t width,
               std::uint32_t height, std::string& error);
