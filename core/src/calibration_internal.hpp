// Private to dco_core: what the calibration sources (calibration.cpp, calibration_text_formats.cpp,
// calibration_toml.cpp) share. Not installed, not part of the public API.
#pragma once

#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "dco/core/calibration.hpp"

namespace dco::detail {

using Mat3 = std::array<double, 9>;
using Vec3 = std::array<double, 3>;

// Throws dco::Error as "file:line: msg", or "file: msg" when line <= 0 (calibration.cpp).
[[noreturn]] void fail_at(const std::string& file, long line, std::string_view msg);

// Cameras and extrinsics of an already rectified pair: ideal pinholes, right camera at +B on x
// (calibration.cpp).
void cameras_from_rectified(StereoCalibration& c);

// ---------------------------------------------------------------------------------------------
// Small 3x3 algebra for composing extrinsics (row-major).

inline Mat3 transpose(const Mat3& a) {
  return {a[0], a[3], a[6], a[1], a[4], a[7], a[2], a[5], a[8]};
}

inline Mat3 mul(const Mat3& a, const Mat3& b) {
  Mat3 r{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) r[i * 3 + j] += a[i * 3 + k] * b[k * 3 + j];
  return r;
}

inline Vec3 mul(const Mat3& a, const Vec3& v) {
  Vec3 r{};
  for (int i = 0; i < 3; ++i) r[i] = a[i * 3] * v[0] + a[i * 3 + 1] * v[1] + a[i * 3 + 2] * v[2];
  return r;
}

// ---------------------------------------------------------------------------------------------
// Text helpers (calibration_text_formats.cpp), also used by format detection.

std::string_view trim(std::string_view s);
std::vector<std::string_view> split_lines(std::string_view text);
bool is_identifier(std::string_view s);

// ---------------------------------------------------------------------------------------------
// Parsers; each returns an unvalidated calibration with `source` set to `file`.

// Middlebury calib.txt (calibration_text_formats.cpp).
StereoCalibration parse_middlebury(std::string_view text, const std::string& file);
// KITTI raw or Karlsruhe "key: numbers" files (calibration_text_formats.cpp).
StereoCalibration parse_key_colon(std::string_view text, const std::string& file);
// dco's TOML format, docs/calibration.md (calibration_toml.cpp).
StereoCalibration parse_toml(std::string_view text, const std::string& file);

// dco's TOML format as text; parse_toml reads it back to the same values (calibration_toml.cpp).
std::string format_toml(const StereoCalibration& calib);

}  // namespace dco::detail
