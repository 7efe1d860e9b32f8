#include "dco/core/image_io.hpp"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <zlib.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/error.hpp"
#include "dco/core/file_replace.hpp"
#include "dco/core/printable.hpp"

namespace dco {
namespace {

std::string quoted(const std::filesystem::path& p) {
  return "'" + p.string() + "'";
}

std::uint32_t read_be32(const std::uint8_t* p) {
  return std::uint32_t{p[0]} << 24 | std::uint32_t{p[1]} << 16 | std::uint32_t{p[2]} << 8 | p[3];
}

// The largest value of a PGM/PPM (P2, P3, P5, P6), whose header is text: magic, width, height,
// maxval, with '#' comments between. nullopt for any other file.
std::optional<long> pnm_maxval(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < 2 || bytes[0] != 'P' ||
      (bytes[1] != '2' && bytes[1] != '3' && bytes[1] != '5' && bytes[1] != '6'))
    return std::nullopt;
  std::size_t i = 2;
  long fields[3] = {};
  for (long& field : fields) {
    while (i < bytes.size() && (std::isspace(bytes[i]) || bytes[i] == '#')) {
      if (bytes[i] == '#')
        while (i < bytes.size() && bytes[i] != '\n') ++i;
      else
        ++i;
    }
    if (i >= bytes.size() || !std::isdigit(bytes[i])) return std::nullopt;
    for (; i < bytes.size() && std::isdigit(bytes[i]) && field < 1'000'000; ++i)
      field = field * 10 + (bytes[i] - '0');
  }
  return fields[2];
}

const char* depth_name(int depth) {
  switch (depth) {
    case CV_16U:
    case CV_16S:
      return "16-bit";
    case CV_32F:
      return "32-bit float";
    case CV_64F:
      return "64-bit float";
    default:
      return "not 8-bit";
  }
}

}  // namespace

std::optional<PngHeader> png_header(std::span<const std::uint8_t> bytes) {
  // Signature, then the IHDR chunk: length, type, 13 bytes of data, CRC.
  static constexpr std::uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (bytes.size() < 33 || !std::equal(kSignature, kSignature + 8, bytes.begin()) ||
      !std::equal(bytes.begin() + 12, bytes.begin() + 16, "IHDR"))
    return std::nullopt;
  return PngHeader{read_be32(bytes.data() + 16), read_be32(bytes.data() + 20), bytes[24]};
}

std::string png_damage(std::span<const std::uint8_t> bytes) {
  constexpr std::size_t kSignature = 8;
  if (bytes.size() < kSignature) return "shorter than a PNG signature";
  std::size_t at = kSignature;
  while (true) {
    if (bytes.size() - at < 12)
      return fmt::format("cut short at byte {} of {} (no IEND chunk)", at, bytes.size());
    const std::uint32_t length = read_be32(bytes.data() + at);
    const std::string type(reinterpret_cast<const char*>(bytes.data() + at + 4), 4);
    // Length, type, data, CRC; the length is at most 2^31 - 1 by the format.
    if (length > 0x7fffffffu || bytes.size() - at - 12 < length)
      return fmt::format("cut short in chunk {} at byte {} of {}", printable(type), at,
                         bytes.size());
    const std::uint8_t* typed = bytes.data() + at + 4;
    const auto crc = static_cast<std::uint32_t>(crc32(crc32(0, nullptr, 0), typed, length + 4));
    if (crc != read_be32(typed + 4 + length))
      return fmt::format("chunk {} at byte {} is damaged (its CRC does not match)", printable(type),
                         at);
    at += 12 + length;
    if (type == "IEND") return {};
  }
}

cv::Mat read_image_file(const std::filesystem::path& path, int flags, std::string_view what) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    throw Error(fmt::format("{} {} does not exist", what, quoted(path)));
  if (!std::filesystem::is_regular_file(path, ec))
    throw Error(fmt::format("{} {} is not a regular file", what, quoted(path)));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("cannot open {} {}", what, quoted(path)));
  const std::vector<std::uint8_t> bytes(std::istreambuf_iterator<char>(in), {});
  if (const auto png = png_header(bytes)) {
    if (png->width > static_cast<std::uint32_t>(kMaxImageSide) ||
        png->height > static_cast<std::uint32_t>(kMaxImageSide))
      throw Error(fmt::format("{} {} is a {}x{} PNG (sides at most {})", what, quoted(path),
                              png->width, png->height, kMaxImageSide));
    if (const std::string damage = png_damage(bytes); !damage.empty())
      throw Error(fmt::format("cannot decode {} {}: the PNG is {}", what, quoted(path), damage));
  }
  // OpenCV reads a PGM/PPM of fewer levels (maxval 15) as 8-bit values 0..15, unscaled.
  if (const auto maxval = pnm_maxval(bytes); maxval && *maxval < 255)
    throw Error(fmt::format("{} {} is a PGM/PPM with maxval {} (8-bit ones need 255)", what,
                            quoted(path), *maxval));
  cv::Mat m;
  try {
    if (!bytes.empty()) m = cv::imdecode(bytes, flags);
  } catch (const cv::Exception& e) {
    throw Error(fmt::format("cannot decode {} {}: {}", what, quoted(path), e.err));
  }
  if (m.empty())
    throw Error(fmt::format("cannot decode {} {} (corrupt or unsupported)", what, quoted(path)));
  if (m.cols > kMaxImageSide || m.rows > kMaxImageSide)
    throw Error(fmt::format("{} {} is {}x{} (sides at most {})", what, quoted(path), m.cols, m.rows,
                            kMaxImageSide));
  return m;
}

Image<std::uint8_t> load_image(const std::filesystem::path& path, ImageColor color) {
  // ANYDEPTH so that 16-bit files are seen (and refused) instead of silently scaled down;
  // ANYCOLOR keeps grey files grey and drops alpha.
  cv::Mat m = read_image_file(path, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR, "image");
  if (m.depth() != CV_8U)
    throw Error("image " + quoted(path) + " is " + depth_name(m.depth()) +
                "; only 8-bit images are supported");
  if (color == ImageColor::kGray && m.channels() == 3) cv::cvtColor(m, m, cv::COLOR_BGR2GRAY);
  if (color == ImageColor::kColor && m.channels() == 1) cv::cvtColor(m, m, cv::COLOR_GRAY2BGR);
  if (m.channels() != 1 && m.channels() != 3)
    throw Error("image " + quoted(path) + " has " + std::to_string(m.channels()) + " channels");
  Image<std::uint8_t> out(m.cols, m.rows, m.channels());
  out.copy_from(as_view<std::uint8_t>(std::as_const(m)));
  return out;
}

void save_image(const std::filesystem::path& path, ImageView<const std::uint8_t> image) {
  if (image.empty() || (image.channels != 1 && image.channels != 3 && image.channels != 4))
    throw Error("cannot write image " + quoted(path) +
                ": it must be non-empty with 1, 3 or 4 channels");
  write_image_file(path, as_mat(image), "image");
}

void write_image_file(const std::filesystem::path& path, const cv::Mat& image,
                      std::string_view what) {
  const std::string name = "cannot write " + std::string(what) + " " + quoted(path);
  replace_file(path, [&](const std::filesystem::path& tmp) {
    bool ok = false;
    try {
      ok = cv::imwrite(tmp.string(), image);
    } catch (const cv::Exception& e) {
      throw Error(name + ": " + e.err);
    }
    if (!ok) throw Error(name);
  });
}

}  // namespace dco
