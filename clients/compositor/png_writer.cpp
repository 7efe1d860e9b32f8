// PNG output through libpng.

#include <png.h>

#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "dco/compositor/renderer.hpp"
#include "dco/replacing_file.hpp"

namespace dco::compositor {

namespace {

// libpng's own handler prints "libpng error: ..." before the tool's line; this one keeps the
// message for it and jumps back as libpng requires.
void on_png_error(png_structp png, png_const_charp message) {
  auto* text = static_cast<std::string*>(png_get_error_ptr(png));
  if (text != nullptr) *text = message != nullptr ? message : "";
  png_longjmp(png, 1);
}

void on_png_warning(png_structp, png_const_charp) {}

}  // namespace

void write_png(const std::string& path, const std::uint8_t* pixels, int width, int height,
               int channels) {
  if (channels != 1 && channels != 3 && channels != 4)
    throw Error("png: 1, 3 or 4 channels, not " + std::to_string(channels));
  // Written beside it under a name of its own and renamed over it: a reader never sees half a
  // PNG, and a failed write (a full disk) leaves the last good one.
  client_tools::ReplacingFile out(path);
  if (out.file() == nullptr) throw Error("png: cannot create: " + out.error());
  std::string png_message;
  png_structp png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, &png_message, on_png_error, on_png_warning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_write_struct(&png, nullptr);
    throw Error("png '" + path + "': out of memory");
  }
  std::vector<png_bytep> rows(static_cast<std::size_t>(height));
  for (int y = 0; y < height; ++y)
    rows[static_cast<std::size_t>(y)] =
        const_cast<png_bytep>(pixels + static_cast<std::size_t>(y) * width * channels);
  // libpng reports errors by longjmp; nothing with a destructor is created past this point.
  if (setjmp(png_jmpbuf(png))) {
    const int err = errno;
    png_destroy_write_struct(&png, &info);
    throw Error("png '" + path + "': write failed (" + png_message +
                (err != 0 ? std::string(": ") + std::strerror(err) : std::string()) + ")");
  }
  png_init_io(png, out.file());
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 8,
               channels == 4   ? PNG_COLOR_TYPE_RGBA
               : channels == 3 ? PNG_COLOR_TYPE_RGB
                               : PNG_COLOR_TYPE_GRAY,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_compression_level(png, 3);
  png_write_info(png, info);
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  if (!out.commit()) throw Error("png: write failed: " + out.error());
}

}  // namespace dco::compositor
