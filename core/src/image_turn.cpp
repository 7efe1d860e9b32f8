#include "dco/core/image_turn.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

namespace dco {

namespace {

// cv::warpAffine's fixed point (OpenCV 4 imgwarp.cpp): the map in 1/1024 px, rounded to the
// 1/32 px of the remap tables; bilinear weights in 1/1024 that sum to one.
constexpr int kMapBits = 10;
constexpr int kFractionBits = 5;
constexpr int kFraction = 1 << kFractionBits;
constexpr int kRoundDelta = (1 << kMapBits) / kFraction / 2;
constexpr int kWeightBits = 2 * kFractionBits;

// Columns are turned in strips, so that each column's share of the map is worked out once.
constexpr int kStrip = 256;
// Images with more channels than this are turned pixel by pixel.
constexpr int kMaxRunChannels = 4;

// Where an output pixel samples the source: whole pixel and 1/32 fractions.
struct Sample {
  int px, py, ax, ay;
};

// Columns [x0, x0 + n) of one output row: `X0`/`Y0` hold the row's share of the map, `dx`/`dy`
// each column's, rounded on its own as OpenCV's per-column tables are.
struct RowMap {
  int X0, Y0;
  const int* dx;
  const int* dy;
  // Column i's source position in 1/32 px.
  int x(int i) const { return (X0 + dx[i]) >> (kMapBits - kFractionBits); }
  int y(int i) const { return (Y0 + dy[i]) >> (kMapBits - kFractionBits); }
  Sample at(int i) const {
    const int X = x(i), Y = y(i);
    return {cv::saturate_cast<short>(X >> kFractionBits),
            cv::saturate_cast<short>(Y >> kFractionBits), X & (kFraction - 1), Y & (kFraction - 1)};
  }
};

// One pixel's channel from its four samples, as OpenCV's remap: weights in 1/1024, rounded.
std::uint8_t blend(int a, int b, int c, int d, const Sample& s) {
  const int v = a * (kFraction - s.ax) * (kFraction - s.ay) + b * s.ax * (kFraction - s.ay) +
                c * (kFraction - s.ax) * s.ay + d * s.ax * s.ay;
  return static_cast<std::uint8_t>((v + (1 << (kWeightBits - 1))) >> kWeightBits);
}

// `n` bytes of a run whose pixels sample consecutive source pixels of the same two rows at the
// same horizontal fraction `ax`, each byte with its own vertical weight `down` (ay << 10): in
// 16-bit lanes the compiler vectorises. The same integer as blend(): with h0, h1 the two rows'
// horizontal blends (at most 32 * 255), (32 h0 + ay (h1 - h0) + 512) >> 10 equals
// (h0 + floor(ay (h1 - h0) / 32) + 16) >> 5, and that floor is the high half of
// 2 (h1 - h0) times ay << 10.
void blend_run(const std::uint8_t* r0, const std::uint8_t* r1, int cn, int n, int ax,
               const std::int16_t* down, std::uint8_t* out) {
  const auto left = static_cast<std::int16_t>(kFraction - ax),
             right = static_cast<std::int16_t>(ax);
  for (int i = 0; i < n; ++i) {
    const auto h0 = static_cast<std::int16_t>(left * r0[i] + right * r0[i + cn]);
    const auto h1 = static_cast<std::int16_t>(left * r1[i] + right * r1[i + cn]);
    const auto d2 = static_cast<std::int16_t>(2 * (h1 - h0));
    const auto t = static_cast<std::int16_t>((d2 * down[i]) >> 16);
    out[i] = static_cast<std::uint8_t>((h0 + t + kFraction / 2) >> kFractionBits);
  }
}

// `n` pixels of one output row from column x0 on. A small roll keeps the horizontal fraction
// and the source row for many pixels in a row; such runs inside the image are blended as one,
// the other pixels one by one with each of the four samples' coordinates clamped on its own
// (borders repeated). `down` is room for n * channels vertical weights.
void turn_columns(ImageView<const std::uint8_t> src, const RowMap& map, int x0, int n,
                  std::uint8_t* out, std::int16_t* down) {
  const int cn = src.channels, w = src.width, h = src.height;
  const bool runs = cn <= kMaxRunChannels;
  if (runs)
    for (int i = 0; i < n; ++i) {
      const auto d = static_cast<std::int16_t>((map.y(i) & (kFraction - 1)) << (2 * kFractionBits));
      for (int k = 0; k < cn; ++k) down[i * cn + k] = d;
    }
  int i = 0;
  while (i < n) {
    const Sample s = map.at(i);
    std::uint8_t* o = out + (x0 + i) * cn;
    if (runs && s.px >= 0 && s.px < w - 1 && s.py >= 0 && s.py < h - 1) {
      // The run goes on while each next pixel sits one whole pixel further right at the same
      // fraction, between the same two rows.
      const int X = map.x(i) - kFraction * i;
      int run = 1;
      while (i + run < n && s.px + run < w - 1 && map.x(i + run) - kFraction * (i + run) == X &&
             map.y(i + run) >> kFractionBits == s.py)
        ++run;
      const std::uint8_t* r0 = src.row(s.py) + s.px * cn;
      blend_run(r0, r0 + src.stride, cn, run * cn, s.ax, down + i * cn, o);
      i += run;
      continue;
    }
    const int c0 = std::clamp(s.px, 0, w - 1) * cn, c1 = std::clamp(s.px + 1, 0, w - 1) * cn;
    const std::uint8_t* r0 = src.row(std::clamp(s.py, 0, h - 1));
    const std::uint8_t* r1 = src.row(std::clamp(s.py + 1, 0, h - 1));
    for (int k = 0; k < cn; ++k) o[k] = blend(r0[c0 + k], r0[c1 + k], r1[c0 + k], r1[c1 + k], s);
    ++i;
  }
}

}  // namespace

void turn_about_centre(ImageView<const std::uint8_t> src, double radians, double down,
                       Image<std::uint8_t>& out) {
  out.resize(src.width, src.height, src.channels);
  const double c = std::cos(radians), s = std::sin(radians);
  const double xc = 0.5 * (src.width - 1), yc = 0.5 * (src.height - 1);
  // The map from out to src: (x, y) -> (c x - s y + m02, s x + c y + m12).
  const double m02 = xc - c * xc + s * yc, m12 = yc - s * xc - c * yc + down;
  const ImageView<std::uint8_t> o = out.view();
  int dx[kStrip], dy[kStrip];
  std::int16_t weights[kStrip * kMaxRunChannels];
  for (int x0 = 0; x0 < src.width; x0 += kStrip) {
    const int n = std::min(kStrip, src.width - x0);
    for (int i = 0; i < n; ++i) {
      dx[i] = cv::saturate_cast<int>(c * (x0 + i) * (1 << kMapBits));
      dy[i] = cv::saturate_cast<int>(s * (x0 + i) * (1 << kMapBits));
    }
    for (int y = 0; y < src.height; ++y) {
      const RowMap map{cv::saturate_cast<int>((-s * y + m02) * (1 << kMapBits)) + kRoundDelta,
                       cv::saturate_cast<int>((c * y + m12) * (1 << kMapBits)) + kRoundDelta, dx,
                       dy};
      turn_columns(src, map, x0, n, o.row(y), weights);
    }
  }
}

}  // namespace dco
