#include "overlay.hpp"

#include <cmath>
#include <cstdio>
#include <vector>

#include "dco/replacing_file.hpp"

void render_occlusion_overlay(const dco::client::FrameView& frame, double virtual_depth_m,
                              std::vector<std::uint8_t>& rgb) {
  const dco_frame_info& info = frame.info();
  const std::uint32_t w = info.width, h = info.height;
  // The virtual box covers the middle half of the view in both directions.
  const std::uint32_t x0 = w / 4, x1 = w - w / 4, y0 = h / 4, y1 = h - h / 4;
  rgb.resize(std::size_t{w} * h * 3);
  for (std::uint32_t y = 0; y < h; ++y) {
    const float* depth = frame.depth_row(y);
    const std::uint8_t* image = frame.image_row(y);
    for (std::uint32_t x = 0; x < w; ++x) {
      unsigned char grey = 0;
      if (image != nullptr) {
        grey = image[x * info.image_channels];
      } else if (std::isfinite(depth[x]) && depth[x] > 0) {
        grey = static_cast<unsigned char>(std::lround(255.0 / (1.0 + depth[x])));  // near = bright
      }
      std::uint8_t* px = &rgb[(std::size_t{y} * w + x) * 3];
      px[0] = px[1] = px[2] = grey;
      const bool inside = x >= x0 && x < x1 && y >= y0 && y < y1;
      // Unknown depth (+inf, NaN, 0 or below) never occludes.
      const bool real_in_front = depth[x] > 0 && depth[x] < virtual_depth_m;
      if (inside && !real_in_front) {
        px[0] = static_cast<unsigned char>(0.3 * grey + 0.7 * 230);
        px[1] = static_cast<unsigned char>(0.3 * grey + 0.7 * 70);
        px[2] = static_cast<unsigned char>(0.3 * grey + 0.7 * 40);
      }
    }
  }
}

bool write_ppm(const std::string& path, const std::vector<std::uint8_t>& rgb, std::uint32_t width,
               std::uint32_t height, std::string& error) {
  dco::client_tools::ReplacingFile out(path);
  if (out.file() == nullptr) {
    error = out.error();
    return false;
  }
  const bool written = std::fprintf(out.file(), "P6\n%u %u\n255\n", width, height) > 0 &&
                       std::fwrite(rgb.data(), 1, rgb.size(), out.file()) == rgb.size();
  if (!out.commit(written)) {
    error = out.error();
    return false;
  }
  return true;
}
