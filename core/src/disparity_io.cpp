#include "dco/core/disparity_io.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include <opencv2/imgcodecs.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/error.hpp"
#include "dco/core/file_replace.hpp"
#include "dco/core/image_io.hpp"

namespace dco {
namespace {

std::string quoted(const std::filesystem::path& p) {
  return "'" + p.string() + "'";
}

// Reads one whitespace-delimited header token; PFM headers may put tokens on one line or several.
std::string next_token(std::istream& in) {
  std::string token;
  in >> token;
  return token;
}

// Whole tokens only ("4abc" is no width); throws std::invalid_argument or std::out_of_range.
long whole_long(const std::string& token) {
  std::size_t used = 0;
  const long v = std::stol(token, &used);
  if (used != token.size()) throw std::invalid_argument(token);
  return v;
}

double whole_double(const std::string& token) {
  std::size_t used = 0;
  const double v = std::stod(token, &used);
  if (used != token.size()) throw std::invalid_argument(token);
  return v;
}

std::uint32_t byteswap32(std::uint32_t v) {
  return (v >> 24) | ((v >> 8) & 0xff00u) | ((v << 8) & 0xff0000u) | (v << 24);
}

Image<std::uint16_t> read_png16(const std::filesystem::path& path, const char* what) {
  // Unchanged: a grey conversion would mix a colour PNG's channels (KITTI's optical flow is one)
  // into values that look like a map.
  const cv::Mat m = read_image_file(path, cv::IMREAD_UNCHANGED, std::string(what) + " PNG");
  if (m.depth() != CV_16U)
    throw Error(quoted(path) + " is not a 16-bit PNG (" + std::string(what) + " needs 16 bits)");
  if (m.channels() != 1)
    throw Error(quoted(path) + " has " + std::to_string(m.channels()) + " channels (" +
                std::string(what) + " needs one)");
  Image<std::uint16_t> out(m.cols, m.rows);
  out.copy_from(as_view<std::uint16_t>(std::as_const(m)));
  return out;
}

void write_png16(const std::filesystem::path& path, const Image<std::uint16_t>& img) {
  write_image_file(path, as_mat(img.view()), "PNG");
}

// Both 16-bit PNG conventions store round(value * scale) with 0 meaning unknown; values that are
// not finite or not positive are written as 0 and large ones clamp to 65535.
void write_scaled_png16(const std::filesystem::path& path, ImageView<const float> image,
                        float scale, const char* what) {
  if (image.empty() || image.channels != 1)
    throw Error("cannot write " + quoted(path) + ": " + what + " must be a one-channel image");
  Image<std::uint16_t> q(image.width, image.height);
  for (int y = 0; y < image.height; ++y) {
    const float* s = image.row(y);
    std::uint16_t* d = q.row(y);
    for (int x = 0; x < image.width; ++x) {
      const float v = s[x];
      // Clamped before rounding: lround of a value beyond a long's range is undefined.
      d[x] = (!std::isfinite(v) || v <= 0)
                 ? 0
                 : static_cast<std::uint16_t>(std::lround(std::clamp(v * scale, 1.0f, 65535.0f)));
    }
  }
  write_png16(path, q);
}

// Returns value / scale, with +inf where the file has 0.
Image<float> read_scaled_png16(const std::filesystem::path& path, float scale, const char* what) {
  const Image<std::uint16_t> q = read_png16(path, what);
  Image<float> out(q.width(), q.height());
  const float unknown = std::numeric_limits<float>::infinity();
  for (int y = 0; y < q.height(); ++y)
    for (int x = 0; x < q.width(); ++x) {
      const std::uint16_t v = q.at(x, y);
      out.at(x, y) = v == 0 ? unknown : static_cast<float>(v) / scale;
    }
  return out;
}

}  // namespace

Image<float> read_pfm(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open PFM " + quoted(path));
  const std::string magic = next_token(in);
  int channels = 0;
  if (magic == "Pf")
    channels = 1;
  else if (magic == "PF")
    channels = 3;
  else
    throw Error(quoted(path) + " is not a PFM file (magic '" + magic.substr(0, 8) + "')");
  long width = 0, height = 0;
  double scale = 0;
  try {
    width = whole_long(next_token(in));
    height = whole_long(next_token(in));
    scale = whole_double(next_token(in));
  } catch (const std::exception&) {
    throw Error(quoted(path) + ": malformed PFM header");
  }
  if (width <= 0 || height <= 0 || width > kMaxImageSide || height > kMaxImageSide || scale == 0 ||
      !std::isfinite(scale))
    throw Error(quoted(path) + ": bad PFM header (size " + std::to_string(width) + "x" +
                std::to_string(height) + ", scale " + std::to_string(scale) + ")");
  // The header ends in whitespace (one byte by the format, but writers add a space or a CR), and
  // the data fills the rest of the file exactly: anything else would be read shifted. It must be
  // there before it is allocated: a 20-byte header can ask for gigabytes.
  constexpr std::streamoff kMostHeaderPadding = 8;
  const std::size_t data_bytes =
      static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * channels * sizeof(float);
  const std::streampos header_end = in.tellg();
  in.seekg(0, std::ios::end);
  const std::streamoff after_header = in.tellg() - header_end;
  in.seekg(header_end);
  const std::streamoff padding = after_header - static_cast<std::streamoff>(data_bytes);
  if (!in || padding < 1)
    throw Error(quoted(path) + ": PFM data is truncated (" +
                std::to_string(std::max<std::streamoff>(after_header - 1, 0)) + " of " +
                std::to_string(data_bytes) + " bytes)");
  const auto is_padding = [&in] {
    const int c = in.get();
    return c == ' ' || c == '\t' || c == '\r' || c == '\n';
  };
  bool header_padding = padding <= kMostHeaderPadding;
  for (std::streamoff i = 0; header_padding && i < padding; ++i) header_padding = is_padding();
  if (!header_padding)
    throw Error(quoted(path) + ": PFM holds " + std::to_string(padding - 1) +
                " bytes more than its " + std::to_string(width) + "x" + std::to_string(height) +
                " data and the byte that ends its header");
  const bool little = scale < 0;
  const bool swap = little != (std::endian::native == std::endian::little);

  Image<float> out(static_cast<int>(width), static_cast<int>(height), channels);
  const std::size_t row_floats = static_cast<std::size_t>(width) * channels;
  for (long y = height - 1; y >= 0; --y) {
    float* r = out.row(static_cast<int>(y));
    in.read(reinterpret_cast<char*>(r), static_cast<std::streamsize>(row_floats * sizeof(float)));
    if (!in) throw Error(quoted(path) + ": PFM data is truncated");
    if (swap) {
      for (std::size_t i = 0; i < row_floats; ++i) {
        std::uint32_t bits;
        std::memcpy(&bits, &r[i], 4);
        bits = byteswap32(bits);
        std::memcpy(&r[i], &bits, 4);
      }
    }
  }
  return out;
}

void write_pfm(const std::filesystem::path& path, ImageView<const float> image) {
  if (image.empty() || (image.channels != 1 && image.channels != 3))
    throw Error("cannot write " + quoted(path) +
                ": PFM holds 1 or 3 channels of a non-empty image");
  replace_file(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw Error("cannot create " + quoted(path));
    const float scale = std::endian::native == std::endian::little ? -1.0f : 1.0f;
    out << (image.channels == 1 ? "Pf" : "PF") << '\n'
        << image.width << ' ' << image.height << '\n'
        << scale << '\n';
    const std::size_t row_floats = static_cast<std::size_t>(image.width) * image.channels;
    for (int y = image.height - 1; y >= 0; --y)
      out.write(reinterpret_cast<const char*>(image.row(y)),
                static_cast<std::streamsize>(row_floats * sizeof(float)));
    out.close();  // the last bytes reach the file here: a full disk shows only now
    if (!out) throw Error("write to " + quoted(path) + " failed");
  });
}

void write_disparity_png16(const std::filesystem::path& path, ImageView<const float> disparity) {
  write_scaled_png16(path, disparity, 256.0f, "disparity");
}

Image<float> read_disparity_png16(const std::filesystem::path& path) {
  return read_scaled_png16(path, 256.0f, "disparity");
}

void write_depth_png16(const std::filesystem::path& path, ImageView<const float> depth_m) {
  write_scaled_png16(path, depth_m, 1000.0f, "depth");
}

Image<float> read_depth_png16(const std::filesystem::path& path) {
  return read_scaled_png16(path, 1000.0f, "depth");
}

}  // namespace dco
