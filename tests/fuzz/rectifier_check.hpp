#pragma once

// Shared by the calibration targets: a calibration that was accepted either gives the rectifier
// a clear dco::Error or a rectified geometry that depth can be computed with.

#include <cmath>
#include <cstdlib>
#include <optional>

#include "dco/core/calibration.hpp"
#include "dco/core/error.hpp"
#include "dco/core/rectifier.hpp"

namespace dco::fuzz {

inline bool usable_geometry(const RectifiedGeometry& g) {
  return std::isfinite(g.f) && g.f > 0 && std::isfinite(g.cx_left) && std::isfinite(g.cx_right) &&
         std::isfinite(g.cy) && std::isfinite(g.baseline_m) && g.baseline_m > 0 && g.width >= 0 &&
         g.height >= 0;
}

// The rectifier of `c`, or nullopt when it refuses `c` with a message; aborts on anything else.
inline std::optional<Rectifier> checked_rectifier(const StereoCalibration& c) {
  std::optional<Rectifier> rectifier;
  try {
    rectifier.emplace(c);
  } catch (const Error& e) {
    if (e.what()[0] == '\0') std::abort();
    return std::nullopt;
  }
  if (!usable_geometry(rectifier->geometry())) std::abort();
  return rectifier;
}

}  // namespace dco::fuzz
