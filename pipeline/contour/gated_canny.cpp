#include "dco/pipeline/contour/gated_canny.hpp"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstring>

#include "dco/kernels/canny_kernels.hpp"
#include "dco/kernels/contour_pixel.hpp"
#include "dco/kernels/filter_kernels.hpp"
#include "dco/pipeline/contour/separable_filters.hpp"

namespace dco::contour {
namespace {

namespace px = kernels::pixel;

constexpr std::uint8_t kWeak =
    kernels::kCannyWeak;  // passed T_low, not yet linked to a strong pixel
constexpr std::uint8_t kEdge = kernels::kCannyStrong;

// seeds[x] = 1 where pixel x of `row` is weak and one of its eight neighbours strong, for
// 0 < x < w - 1, and 0 at both ends: byte compares the compiler vectorises.
void weak_beside_strong(const std::uint8_t* __restrict above, const std::uint8_t* __restrict row,
                        const std::uint8_t* __restrict below, int w,
                        std::uint8_t* __restrict seeds) {
  seeds[0] = 0;
  seeds[w - 1] = 0;
  for (int x = 1; x < w - 1; ++x) {
    const bool strong = (above[x - 1] == kEdge) | (above[x] == kEdge) | (above[x + 1] == kEdge) |
                        (row[x - 1] == kEdge) | (row[x + 1] == kEdge) | (below[x - 1] == kEdge) |
                        (below[x] == kEdge) | (below[x + 1] == kEdge);
    seeds[x] = static_cast<std::uint8_t>((row[x] == kWeak) & strong);
  }
}

// sobel_magnitude's row y of an image of h rows, whose rows `row(i)` gives: the rows above and
// below clamped to the image.
template <class Row>
void sobel_magnitude_row(Row&& row, int y, int h, int w, float inv, float* magnitude,
                         std::uint8_t* direction) {
  const kernels::SobelRows rows{row(std::max(y - 1, 0)), row(y), row(std::min(y + 1, h - 1)), w};
  kernels::sobel_row(rows, inv, magnitude, direction);
}

}  // namespace

void sobel_magnitude(ImageView<const float> smoothed, float norm, ImageView<float> magnitude,
                     ImageView<std::uint8_t> direction) {
  assert(smoothed.channels == 1 && magnitude.same_size(smoothed) && direction.same_size(smoothed));
  const int w = smoothed.width;
  const int h = smoothed.height;
  const float inv = 1.0f / norm;
  const auto row = [&](int i) { return smoothed.row(i); };
  for (int y = 0; y < h; ++y)
    sobel_magnitude_row(row, y, h, w, inv, magnitude.row(y), direction.row(y));
}

namespace {

// intensity_gradients, calling after_row(y) once gradient row y is written.
template <class AfterRow>
void gradients_rows(ImageView<const std::uint8_t> image, GradientScratch& scratch,
                    Image<float>& m_intensity, Image<std::uint8_t>& direction,
                    AfterRow&& after_row) {
  assert(image.channels == 1);
  const int w = image.width, h = image.height;
  scratch.resize(w);
  m_intensity.resize(w, h);
  direction.resize(w, h);
  if (w == 0 || h == 0) return;
  // Blurred row y lives in the ring's slot y % 3. Gradient row y reads the blurred rows
  // y - 1 .. y + 1 (clamped), so the ring takes row y + 1 once row y - 2 is no longer read.
  const auto blurred = [&](int y) { return scratch.blurred.row(y % 3); };
  const auto blur_row = [&](int y) {
    gaussian_blur_5x5_row(image, y, scratch.blur_tmp.row(0), blurred(y));
  };
  const float inv = 1.0f / kMaxSobelMagnitude8Bit;
  blur_row(0);
  for (int y = 0; y < h; ++y) {
    if (y + 1 < h) blur_row(y + 1);
    sobel_magnitude_row(blurred, y, h, w, inv, m_intensity.row(y), direction.row(y));
    after_row(y);
  }
}

// Suppression and dual threshold of interior row y (1 <= y < h - 1); `gate` per column or null.
void classify_row(ImageView<const float> magnitude, ImageView<const std::uint8_t> direction, int y,
                  const float* gate, const kernels::CannyLevels& levels, std::uint8_t* out) {
  kernels::CannyRow row;
  row.above = magnitude.row(y - 1);
  row.row = magnitude.row(y);
  row.below = magnitude.row(y + 1);
  row.direction = direction.row(y);
  row.gate = gate;
  row.width = magnitude.width;
  kernels::canny_classify_row(row, levels, out);
}

// Sizes the scratch for gate_row on images `w` wide: the gate's column of each image column.
void prepare_gate(ImageView<const float> gate, int w, CannyScratch& scratch) {
  if (gate.empty()) return;
  if (scratch.gate_row.size() < static_cast<std::size_t>(w)) scratch.gate_row.resize(w);
  if (scratch.gate_x.size() < static_cast<std::size_t>(w)) scratch.gate_x.resize(w);
  for (int x = 0; x < w; ++x) scratch.gate_x[x] = px::gate_sample(x, w, gate.width);
}

// The gate of image row y of h, one value per image column (gate_sample): the gate's own row
// when it has the image's width, else gathered into the scratch (prepare_gate first).
const float* gate_row(ImageView<const float> gate, int y, int w, int h, CannyScratch& scratch) {
  const float* g = gate.row(px::gate_sample(y, h, gate.height));
  if (gate.width == w) return g;
  if (2 * gate.width == w)  // gate_sample's column is x / 2
    kernels::repeat_pairs(g, w, scratch.gate_row.data());
  else
    for (int x = 0; x < w; ++x) scratch.gate_row[x] = g[scratch.gate_x[x]];
  return scratch.gate_row.data();
}

void zero_rows(ImageView<std::uint8_t> image, int begin, int end) {
  for (int y = begin; y < end; ++y)
    std::memset(image.row(y), 0, static_cast<std::size_t>(image.width));
}

// Zeroes the rows of a Canny map that no pass over its interior rows writes (those rows are
// written whole, border columns included): every row of a map under 3x3, else the first and the
// last. Returns whether the map has interior rows.
bool zero_canny_border(ImageView<std::uint8_t> map) {
  const int h = map.height;
  if (map.width < 3 || h < 3) {
    zero_rows(map, 0, h);
    return false;
  }
  zero_rows(map, 0, 1);
  zero_rows(map, h - 1, h);
  return true;
}

}  // namespace

void intensity_gradients(ImageView<const std::uint8_t> image, GradientScratch& scratch,
                         Image<float>& m_intensity, Image<std::uint8_t>& direction) {
  gradients_rows(image, scratch, m_intensity, direction, [](int) {});
}

void intensity_gradients_and_classes(ImageView<const std::uint8_t> image, const CannyThresholds& t,
                                     GradientScratch& scratch, Image<float>& m_intensity,
                                     Image<std::uint8_t>& direction, Image<std::uint8_t>& classes) {
  classes.resize(image.width, image.height);
  const bool interior = zero_canny_border(classes.view());
  const kernels::CannyLevels levels{t.low, t.high, t.depth};
  gradients_rows(image, scratch, m_intensity, direction, [&](int y) {
    // Row y - 1 reads gradient rows y - 2 .. y, all written now.
    if (interior && y >= 2)
      classify_row(m_intensity.cview(), direction.cview(), y - 1, nullptr, levels,
                   classes.row(y - 1));
  });
}

void canny_classes(ImageView<const float> magnitude, ImageView<const std::uint8_t> direction,
                   const CannyThresholds& t, ImageView<std::uint8_t> classes) {
  assert(magnitude.channels == 1 && direction.same_size(magnitude) && classes.same_size(magnitude));
  const int h = magnitude.height;
  if (!zero_canny_border(classes)) return;
  const kernels::CannyLevels levels{t.low, t.high, t.depth};
  for (int y = 1; y < h - 1; ++y)
    classify_row(magnitude, direction, y, nullptr, levels, classes.row(y));
}

void gated_canny(ImageView<const float> magnitude, ImageView<const std::uint8_t> direction,
                 ImageView<const float> gate, const CannyThresholds& t,
                 ImageView<std::uint8_t> edges, CannyScratch& scratch) {
  assert(magnitude.channels == 1 && direction.same_size(magnitude) && edges.same_size(magnitude));
  const int w = magnitude.width;
  const int h = magnitude.height;
  if (!zero_canny_border(edges)) return;
  // Non-maximum suppression, depth gate and dual threshold, a row at a time. Of two equal maxima
  // side by side only the first (left/upper) survives, so a plateau still thins to one pixel.
  prepare_gate(gate, w, scratch);
  const kernels::CannyLevels levels{t.low, t.high, t.depth};
  for (int y = 1; y < h - 1; ++y)
    classify_row(magnitude, direction, y, gate.empty() ? nullptr : gate_row(gate, y, w, h, scratch),
                 levels, edges.row(y));
  canny_hysteresis(edges, scratch);
}

void gated_canny_classified(ImageView<const std::uint8_t> classes, ImageView<const float> gate,
                            const CannyThresholds& t, ImageView<std::uint8_t> edges,
                            CannyScratch& scratch) {
  assert(classes.channels == 1 && edges.same_size(classes));
  const int w = classes.width;
  const int h = classes.height;
  if (!zero_canny_border(edges)) return;
  prepare_gate(gate, w, scratch);
  for (int y = 1; y < h - 1; ++y) {
    if (gate.empty())
      std::memcpy(edges.row(y), classes.row(y), static_cast<std::size_t>(w));
    else
      kernels::canny_gate_row(classes.row(y), gate_row(gate, y, w, h, scratch), t.depth, w,
                              edges.row(y));
  }
  canny_hysteresis(edges, scratch);
}

void canny_hysteresis(ImageView<std::uint8_t> edges, CannyScratch& scratch) {
  const int w = edges.width;
  const int h = edges.height;
  if (w < 3 || h < 3) return;
  const std::size_t pixels = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  if (scratch.stack.size() < pixels) scratch.stack.resize(pixels);
  std::int32_t* stack = scratch.stack.data();
  std::size_t top = 0;
  std::uint8_t* base = edges.data;
  const std::ptrdiff_t stride = edges.stride;
  // The border rows and columns are 0, so the neighbours of an inner pixel are always inside.
  const std::ptrdiff_t offsets[8] = {-stride - 1, -stride,    -stride + 1, -1,
                                     1,           stride - 1, stride,      stride + 1};
  // The result is every strong pixel and every weak one joined to a strong one through weak ones.
  // Strong pixels far outnumber the weak ones a frame links up, so the search starts from the weak
  // pixels next to a strong one (marked strong at once) rather than from every strong pixel. A
  // row's seeds are found by byte compares over the whole row first; a weak pixel whose strong
  // neighbour was itself seeded in the same row is reached by the growth below instead, so the
  // result is the same. The seeds are read eight bytes at a time, and only the set ones visited.
  scratch.seeds.resize(static_cast<std::size_t>(w) + 8);
  std::uint8_t* seeds = scratch.seeds.data();
  std::fill(seeds + w, seeds + w + 8, std::uint8_t{0});
  for (int y = 1; y < h - 1; ++y) {
    weak_beside_strong(edges.row(y - 1), edges.row(y), edges.row(y + 1), w, seeds);
    const std::ptrdiff_t row = y * stride;
    for (int x = 0; x < w; x += 8) {
      std::uint64_t word;
      std::memcpy(&word, seeds + x, sizeof word);
      // A seed is a byte of 1 (the bytes past the row are 0): the lowest set bit is the next.
      if constexpr (std::endian::native != std::endian::little) word = __builtin_bswap64(word);
      for (; word != 0; word &= word - 1) {
        const int i = x + std::countr_zero(word) / 8;
        base[row + i] = kEdge;
        stack[top++] = static_cast<std::int32_t>(row + i);
      }
    }
  }

  // Grow the seeds through 8-connected weak pixels. Each pixel is marked before it is pushed, so
  // the stack never holds more than one entry per pixel.
  while (top > 0) {
    const std::ptrdiff_t i = stack[--top];
    for (const std::ptrdiff_t o : offsets) {
      std::uint8_t& n = base[i + o];
      if (n == kWeak) {
        n = kEdge;
        stack[top++] = static_cast<std::int32_t>(i + o);
      }
    }
  }
  for (int y = 1; y < h - 1; ++y) {
    std::uint8_t* e = edges.row(y);
    for (int x = 0; x < w; ++x) e[x] = e[x] == kEdge ? kEdge : 0;
  }
}

}  // namespace dco::contour
