// Entry point: arbitrary bytes as an INDEMIND module's calibration blob, taken all the way to the
// StereoCalibration the driver rectifies with, at the module's size and at half of it. A blob the
// parser accepts may still be refused (with a dco::Error) for its geometry; one that is used must
// validate and, at half size, give the rectifier either a clear error or a finite geometry.

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "../../drivers/indemind/module_calibration.hpp"
#include "dco/core/calibration.hpp"
#include "dco/core/error.hpp"
#include "dco/indemind/calibration_blob.hpp"
#include "fuzz_target.hpp"
#include "rectifier_check.hpp"

namespace {

void check(const dco::indemind::ModuleCalibration& m, int width, int height, bool rectify) {
  dco::StereoCalibration c;
  try {
    c = dco::indemind::to_stereo_calibration(m, width, height);
  } catch (const dco::Error& e) {
    if (e.what()[0] == '\0') std::abort();
    return;
  }
  try {
    c.validate();
  } catch (const dco::Error&) {
    std::abort();  // what the driver would use must be valid
  }
  if (rectify) dco::fuzz::checked_rectifier(c);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  dco::indemind::ModuleCalibration m;
  try {
    m = dco::indemind::parse_calibration_blob(std::span<const std::uint8_t>(data, size));
  } catch (const dco::Error&) {
    return 0;
  }
  // The maps cost milliseconds: built at the smaller size only.
  check(m, m.left.width, m.left.height, false);
  check(m, m.left.width / 2, m.left.height / 2, true);
  return 0;
}
