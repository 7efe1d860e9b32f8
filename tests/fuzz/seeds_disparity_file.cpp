// Seeds of the disparity file target: small PFMs of either byte order and channel count (one with
// a CRLF header), and 16-bit PNGs of disparity and depth, written by dco's own writers.

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "dco/core/disparity_io.hpp"
#include "dco/core/image.hpp"
#include "fuzz_target.hpp"
#include "scratch_dir.hpp"

namespace dco::fuzz {
namespace {

std::vector<std::uint8_t> file_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

Image<float> ramp(int width, int height, int channels) {
  Image<float> image(width, height, channels);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width * channels; ++x)
      image.row(y)[x] = (x + y) % 7 == 0 ? INFINITY : 0.25f * static_cast<float>(x + 3 * y + 1);
  return image;
}

// A big-endian one-channel PFM, as some tools write them ("1.0": positive scale).
std::vector<std::uint8_t> big_endian_pfm(int width, int height, const std::string& newline) {
  const std::string header = "Pf" + newline + std::to_string(width) + " " + std::to_string(height) +
                             newline + "1.0" + newline;
  std::vector<std::uint8_t> out(header.begin(), header.end());
  for (int i = 0; i < width * height; ++i) {
    const float v = 0.5f * static_cast<float>(i);
    std::uint32_t bits;
    std::memcpy(&bits, &v, 4);
    for (int b = 3; b >= 0; --b) out.push_back(static_cast<std::uint8_t>(bits >> (8 * b)));
  }
  return out;
}

}  // namespace

std::vector<std::vector<std::uint8_t>> seeds() {
  const ScratchDir dir("disparity_file_seeds");
  std::vector<std::vector<std::uint8_t>> out;
  write_pfm(dir.path() / "one.pfm", ramp(7, 5, 1).cview());
  out.push_back(file_bytes(dir.path() / "one.pfm"));
  write_pfm(dir.path() / "three.pfm", ramp(4, 3, 3).cview());
  out.push_back(file_bytes(dir.path() / "three.pfm"));
  out.push_back(big_endian_pfm(5, 4, "\n"));
  out.push_back(big_endian_pfm(3, 2, "\r\n"));
  write_disparity_png16(dir.path() / "disparity.png", ramp(9, 6, 1).cview());
  out.push_back(file_bytes(dir.path() / "disparity.png"));
  write_depth_png16(dir.path() / "depth.png", ramp(6, 9, 1).cview());
  out.push_back(file_bytes(dir.path() / "depth.png"));
  return out;
}

}  // namespace dco::fuzz
