#include "dco/core/image_io.hpp"

#include <string>
#include <system_error>
#include <utility>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/error.hpp"

namespace dco {
namespace {

std::string quoted(const std::filesystem::path& p) {
  return "'" + p.string() + "'";
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

Image<std::uint8_t> load_image(const std::filesystem::path& path, ImageColor color) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw Error("image " + quoted(path) + " does not exist");
  if (!std::filesystem::is_regular_file(path, ec))
    throw Error("image " + quoted(path) + " is not a regular file");
  // ANYDEPTH so that 16-bit files are seen (and refused) instead of silently scaled down;
  // ANYCOLOR keeps grey files grey and drops alpha.
  cv::Mat m;
  try {
    m = cv::imread(path.string(), cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
  } catch (const cv::Exception& e) {
    throw Error("cannot decode image " + quoted(path) + ": " + e.err);
  }
  if (m.empty()) throw Error("cannot decode image " + quoted(path) + " (corrupt or unsupported)");
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
  bool ok = false;
  try {
    ok = cv::imwrite(path.string(), as_mat(image));
  } catch (const cv::Exception& e) {
    throw Error("cannot write image " + quoted(path) + ": " + e.err);
  }
  if (!ok) throw Error("cannot write image " + quoted(path));
}

}  // namespace dco
