#pragma once

#include <filesystem>

#include "dco/core/image.hpp"

namespace dco {

enum class ImageColor { kAsIs, kGray, kColor };

// Loads an 8-bit image (PNG, PGM, JPEG, ...) as 1 (gray) or 3 (BGR) interleaved channels.
// kAsIs keeps gray files gray and turns everything else into BGR; 16-bit files are refused.
// Throws dco::Error naming the file when it is missing, unreadable or not 8-bit.
Image<std::uint8_t> load_image(const std::filesystem::path& path,
                               ImageColor color = ImageColor::kAsIs);

// Writes an 8-bit image; the format follows the extension. Throws dco::Error on failure.
void save_image(const std::filesystem::path& path, ImageView<const std::uint8_t> image);

}  // namespace dco
