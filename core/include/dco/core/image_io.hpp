#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string_view>

#include <opencv2/core.hpp>

#include "dco/core/image.hpp"

namespace dco {

enum class ImageColor { kAsIs, kGray, kColor };

// Loads an 8-bit image (PNG, PGM, JPEG, ...) as 1 (gray) or 3 (BGR) interleaved channels.
// kAsIs keeps gray files gray and turns everything else into BGR; 16-bit files are refused.
// Throws dco::Error naming the file when it is missing, unreadable or not 8-bit.
Image<std::uint8_t> load_image(const std::filesystem::path& path,
                               ImageColor color = ImageColor::kAsIs);

// What a PNG's IHDR chunk claims, read before decoding so that a small file claiming a huge image
// is refused before it is inflated. nullopt when the bytes do not start as a PNG.
struct PngHeader {
  std::uint32_t width = 0, height = 0;
  int bit_depth = 0;
};
std::optional<PngHeader> png_header(std::span<const std::uint8_t> bytes);

// How a PNG's chunks are damaged (cut short, a chunk's CRC wrong, no IEND), or empty when each
// chunk is whole and its CRC right. Checked before decoding: libpng reports such damage on stderr
// as well as to its caller, which would put a second line beside the tools' and dcod's own.
std::string png_damage(std::span<const std::uint8_t> bytes);

// Reads and decodes an image file as cv::imread(path, flags) would, but every failure -- missing,
// unreadable, corrupt, OpenCV's own exceptions -- is a dco::Error naming the file as `what`, and a
// PNG whose header claims a side above kMaxImageSide is refused before it is inflated (a small
// file can claim gigabytes).
cv::Mat read_image_file(const std::filesystem::path& path, int flags, std::string_view what);

// Writes `image` with OpenCV, the format by the extension, beside its name and renamed over it
// (replace_file): a failed write leaves no file, or the earlier one whole. Any failure is a
// dco::Error naming the file as `what`.
void write_image_file(const std::filesystem::path& path, const cv::Mat& image,
                      std::string_view what);

// Writes an 8-bit image; the format follows the extension. Throws dco::Error on failure.
void save_image(const std::filesystem::path& path, ImageView<const std::uint8_t> image);

}  // namespace dco
