#pragma once

// Row kernels of the gated Canny of the contour stage (dco::contour::gated_canny): non-maximum
// suppression, the depth gate and the dual threshold of one row, and the gate alone on a row
// classified without it. Dispatched at run time like the other kernels; the dco::kernels::scalar
// versions are the reference, and the vector versions give identical results (comparisons only).

#include <cstdint>

namespace dco::kernels {

// Classes of canny_classify_row's output.
inline constexpr std::uint8_t kCannyNone = 0;
inline constexpr std::uint8_t kCannyWeak = 1;  // a maximum at or above T_low, not above T_high
inline constexpr std::uint8_t kCannyStrong = 255;

struct CannyRow {
  const float* above = nullptr;  // magnitude of rows y - 1, y, y + 1
  const float* row = nullptr;
  const float* below = nullptr;
  // Quantised gradient direction per pixel: 0 compare left/right, 1 above-left/below-right,
  // 2 above/below, 3 below-left/above-right (dco::contour::GradientDirection).
  const std::uint8_t* direction = nullptr;
  const float* gate = nullptr;  // per column, null: no gate
  int width = 0;
};

struct CannyLevels {
  float low = 0, high = 0, depth = 0;
};

// out[x] for 1 <= x < width - 1: kCannyNone when the magnitude m is below low, the gate below
// depth, or m is not a maximum along its direction (m > before and m >= after); else
// kCannyStrong when m > high, kCannyWeak otherwise. out[0] and out[width - 1] are kCannyNone.
void canny_classify_row(const CannyRow& row, const CannyLevels& levels, std::uint8_t* out);

// The depth gate on a row canny_classify_row classified without one: out[x] = kCannyNone where
// gate[x] < depth, else classes[x], for x < width. Gating first or after is the same: the gate
// masks single pixels. out may be classes.
void canny_gate_row(const std::uint8_t* classes, const float* gate, float depth, int width,
                    std::uint8_t* out);

namespace scalar {
void canny_classify_row(const CannyRow& row, const CannyLevels& levels, std::uint8_t* out);
void canny_gate_row(const std::uint8_t* classes, const float* gate, float depth, int width,
                    std::uint8_t* out);
}  // namespace scalar

}  // namespace dco::kernels
