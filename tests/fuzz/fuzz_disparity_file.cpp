// Entry point: arbitrary bytes as a PFM file and as a 16-bit PNG of disparity or depth -- ground
// truth and recorded maps that dco-eval, replay and the tests read. Bad files must be refused with
// a dco::Error; a PFM that is accepted must be written back to the same values, and the PNGs give
// +inf or a value in their range.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <optional>
#include <string_view>

#include "dco/core/disparity_io.hpp"
#include "dco/core/error.hpp"
#include "dco/core/image.hpp"
#include "fuzz_target.hpp"
#include "scratch_dir.hpp"

namespace {

using dco::Image;

std::optional<Image<float>> read(const std::function<Image<float>()>& reader) {
  try {
    return reader();
  } catch (const dco::Error& e) {
    if (e.what()[0] == '\0') std::abort();
    return std::nullopt;
  }
}

bool same_bits(const Image<float>& a, const Image<float>& b) {
  if (a.width() != b.width() || a.height() != b.height() || a.channels() != b.channels())
    return false;
  const std::size_t row_bytes = static_cast<std::size_t>(a.width()) * a.channels() * sizeof(float);
  for (int y = 0; y < a.height(); ++y)
    if (std::memcmp(a.row(y), b.row(y), row_bytes) != 0) return false;
  return true;
}

// Every value is unknown (+inf) or within (0, max].
void check_range(const Image<float>& image, float max) {
  for (int y = 0; y < image.height(); ++y)
    for (int x = 0; x < image.width(); ++x) {
      const float v = image.row(y)[x];
      if (!(v == INFINITY || (v > 0 && v <= max))) std::abort();
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const dco::fuzz::ScratchDir dir("disparity_file");
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);

  const std::filesystem::path pfm = dir.write("map.pfm", bytes);
  if (const auto image = read([&] { return dco::read_pfm(pfm); })) {
    if (image->channels() != 1 && image->channels() != 3) std::abort();
    const std::filesystem::path again = dir.path() / "again.pfm";
    dco::write_pfm(again, image->cview());
    const auto reread = read([&] { return dco::read_pfm(again); });
    if (!reread || !same_bits(*image, *reread)) std::abort();
  }

  const std::filesystem::path png = dir.write("map.png", bytes);
  if (const auto disparity = read([&] { return dco::read_disparity_png16(png); })) {
    if (disparity->channels() != 1) std::abort();
    check_range(*disparity, 65535.0f / 256.0f);
  }
  if (const auto depth = read([&] { return dco::read_depth_png16(png); })) {
    if (depth->channels() != 1) std::abort();
    check_range(*depth, 65.535f);
  }
  return 0;
}
