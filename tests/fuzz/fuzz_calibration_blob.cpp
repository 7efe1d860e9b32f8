// libFuzzer entry point: arbitrary bytes as the flash header and as the calibration blob of an
// INDEMIND module. Both parsers must refuse bad input with a dco::Error and never read outside
// it; a blob they accept must encode back to the same fields.

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <span>
#include <vector>

#include "dco/core/error.hpp"
#include "dco/indemind/calibration_blob.hpp"
#include "fuzz_target.hpp"

namespace {

using dco::indemind::ModuleCalibration;

// Byte ranges the codec owns outright (cameras, IMU, v1 and v2 integers); the strings are
// normalised on reading and the SLAM block and padding are not kept.
constexpr std::size_t kNumbersEnd = 1312;
constexpr std::size_t kV1Begin = 1608, kV1End = 1620, kTypeBegin = 1624, kTypeEnd = 1628;

bool same_bytes(std::span<const std::uint8_t> a, const std::vector<std::uint8_t>& b,
                std::size_t begin, std::size_t end) {
  return end <= a.size() && std::memcmp(a.data() + begin, b.data() + begin, end - begin) == 0;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> bytes(data, size);
  try {
    const std::size_t length = dco::indemind::parse_flash_header(bytes);
    if (dco::indemind::calibration_blob_size(0) != length &&
        dco::indemind::calibration_blob_size(1) != length &&
        dco::indemind::calibration_blob_size(2) != length)
      std::abort();
  } catch (const dco::Error& e) {
    if (e.what()[0] == '\0') std::abort();
  }

  ModuleCalibration m;
  try {
    m = dco::indemind::parse_calibration_blob(bytes);
  } catch (const dco::Error& e) {
    if (e.what()[0] == '\0') std::abort();
    return 0;
  }
  std::vector<std::uint8_t> again;
  try {
    again = dco::indemind::encode_calibration_blob(m);
    if (again.size() != size || !(dco::indemind::parse_calibration_blob(again) == m)) std::abort();
  } catch (const dco::Error&) {
    std::abort();  // an accepted blob must have an exact encoding
  }
  if (!same_bytes(bytes, again, 0, kNumbersEnd)) std::abort();
  if (m.version >= 1 && !same_bytes(bytes, again, kV1Begin, kV1End)) std::abort();
  if (m.version >= 2 && !same_bytes(bytes, again, kTypeBegin, kTypeEnd)) std::abort();
  return 0;
}
