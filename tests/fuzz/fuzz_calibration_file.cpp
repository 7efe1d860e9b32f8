// Entry point: arbitrary bytes as a calibration file (Middlebury, KITTI/Karlsruhe or dco's TOML,
// chosen by content) and as TOML text travelling in a recording. Each reader must refuse bad input
// with a dco::Error; a calibration it accepts must validate, write back to the same TOML, and give
// the rectifier either a clear error or a finite geometry it can rectify with.

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "dco/core/calibration.hpp"
#include "dco/core/error.hpp"
#include "dco/core/image.hpp"
#include "dco/core/rectifier.hpp"
#include "fuzz_target.hpp"
#include "rectifier_check.hpp"
#include "scratch_dir.hpp"

namespace {

// Maps of larger images cost milliseconds per input; the parsers are what is fuzzed.
constexpr long kMaxRectifiedPixels = 320 * 240;

void check_rectifier(const dco::StereoCalibration& c) {
  const int w = c.left.width, h = c.left.height;
  if (w <= 0 || h <= 0 || static_cast<long>(w) * h > kMaxRectifiedPixels) return;
  const std::optional<dco::Rectifier> rectifier = dco::fuzz::checked_rectifier(c);
  if (!rectifier || !rectifier->needs_remap()) return;
  dco::Image<std::uint8_t> left(w, h, 1), right(w, h, 1), left_out, right_out;
  rectifier->rectify(left.cview(), right.cview(), left_out, right_out);
  const dco::RectifiedGeometry& g = rectifier->geometry();
  if (left_out.width() != g.width || left_out.height() != g.height) std::abort();
}

void check(const std::function<dco::StereoCalibration()>& read) {
  dco::StereoCalibration c;
  try {
    c = read();
  } catch (const dco::Error& e) {
    if (e.what()[0] == '\0') std::abort();
    return;
  }
  std::string toml;
  try {
    c.validate();
    toml = dco::calibration_to_toml(c);
    if (dco::calibration_to_toml(dco::calibration_from_toml(toml, "again")) != toml) std::abort();
  } catch (const dco::Error&) {
    std::abort();  // what a reader accepts is valid and has an exact TOML form
  }
  if (c.is_rectified && !dco::fuzz::usable_geometry(c.rectified)) std::abort();
  check_rectifier(c);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  check([&] { return dco::calibration_from_toml(text, "recording"); });

  static const dco::fuzz::ScratchDir dir("calibration");
  const std::filesystem::path path = dir.write("calib.txt", text);
  check([&] { return dco::load_calibration(path); });
  return 0;
}
