#pragma once

#include <cstdint>
#include <vector>

#include "dco/core/image.hpp"

// Canny with a depth gate (§5.3): non-maximum suppression, then the paper's extra test that drops a
// pixel whose depth-contour filter M_fuse is below T_depth, then the dual threshold with
// 8-connected hysteresis. Written here because OpenCV's Canny offers no hook for the gate.
namespace dco::contour {

// Quantised gradient direction, the axis along which non-maximum suppression compares.
enum GradientDirection : std::uint8_t {
  kHorizontal = 0,    // gradient along x: compare left and right
  kDiagonalDown = 1,  // along (1, 1) in image coordinates (y down)
  kVertical = 2,      // gradient along y: compare above and below
  kDiagonalUp = 3,    // along (1, -1)
};

// Largest 3x3 Sobel magnitude sqrt(gx² + gy²) an 8-bit image can produce: 255·√20 (gx = 1020,
// gy = 510, e.g. the left column and the top-centre pixel at 0, the rest at 255). A blur first
// keeps values in [0, 255], so it cannot exceed this either.
inline constexpr float kMaxSobelMagnitude8Bit = 1140.3946f;

// 3x3 Sobel on `smoothed` (replicated border). `magnitude` = sqrt(gx² + gy²) / `norm`, so with
// norm = kMaxSobelMagnitude8Bit an 8-bit source maps into [0, 1] with the same scale on every
// frame. `direction` receives a GradientDirection per pixel. All views have one size.
void sobel_magnitude(ImageView<const float> smoothed, float norm, ImageView<float> magnitude,
                     ImageView<std::uint8_t> direction);

// Working memory of intensity_gradients: a row of the vertical blur and the last three rows of
// the blurred image, sized on first use (or by resize, for images `width` pixels wide).
struct GradientScratch {
  Image<float> blur_tmp, blurred;
  void resize(int width) {
    blur_tmp.resize(width, 1);
    blurred.resize(width, 3);
  }
};

// M_I of Eq. 17 and each pixel's gradient direction for a grey image: the 5x5 Gaussian blur
// (gaussian_blur_5x5), then sobel_magnitude with norm kMaxSobelMagnitude8Bit, the same bytes.
// Row by row: each blurred row is made just before the gradients that read it, so the blurred
// image never goes to memory in full. Resizes m_intensity and direction to the image's size
// (allocating only when it grows).
void intensity_gradients(ImageView<const std::uint8_t> image, GradientScratch& scratch,
                         Image<float>& m_intensity, Image<std::uint8_t>& direction);

struct CannyThresholds {
  float high = 0.06f;   // T_high: a suppressed maximum above it starts an edge
  float low = 0.03f;    // T_low: at or above it, a maximum may continue an edge
  float depth = 0.03f;  // T_depth: pixels whose gate value is below it are never edges
};

// Reused between calls; it grows to the image size once and then stays.
struct CannyScratch {
  std::vector<std::int32_t> stack;   // hysteresis work list, one slot per pixel at most
  std::vector<std::int32_t> gate_x;  // column of the gate image for each image column
  std::vector<float> gate_row;       // the gate of one image row, per image column
  std::vector<std::uint8_t> seeds;   // hysteresis seeds of one row, and eight zero bytes
};

// intensity_gradients, and canny_classes of its output (`classes` resized to the image), in one
// pass: each row is classified as soon as the row below it has its gradients.
void intensity_gradients_and_classes(ImageView<const std::uint8_t> image,
                                     const CannyThresholds& thresholds, GradientScratch& scratch,
                                     Image<float>& m_intensity, Image<std::uint8_t>& direction,
                                     Image<std::uint8_t>& classes);

// Writes 255 on edge pixels of `edges` and 0 elsewhere. `gate` (may be empty: no gating) can be
// smaller than the image: pixel (x, y) reads gate(x * gate.width / width, y * gate.height /
// height), i.e. (x / scale, y / scale) rounded down. The one-pixel image border is never an edge.
void gated_canny(ImageView<const float> magnitude, ImageView<const std::uint8_t> direction,
                 ImageView<const float> gate, const CannyThresholds& thresholds,
                 ImageView<std::uint8_t> edges, CannyScratch& scratch);

// The suppression and dual threshold of gated_canny without its gate: kernels::kCannyNone,
// kCannyWeak or kCannyStrong per pixel, kCannyNone on the one-pixel border. They need only the
// image, so a frame's classes can be made before its gate (the depth-contour filter) exists.
void canny_classes(ImageView<const float> magnitude, ImageView<const std::uint8_t> direction,
                   const CannyThresholds& thresholds, ImageView<std::uint8_t> classes);

// gated_canny given the classes canny_classes made of the same magnitude and directions with the
// same thresholds: the same bytes, with the gate applied to the classes.
void gated_canny_classified(ImageView<const std::uint8_t> classes, ImageView<const float> gate,
                            const CannyThresholds& thresholds, ImageView<std::uint8_t> edges,
                            CannyScratch& scratch);

// The hysteresis step of gated_canny on its classified map (0, kernels::kCannyWeak,
// kernels::kCannyStrong, with 0 on the border rows and columns): every weak pixel 8-connected to
// a strong one through weak ones becomes 255, everything else 0.
void canny_hysteresis(ImageView<std::uint8_t> edges, CannyScratch& scratch);

}  // namespace dco::contour
