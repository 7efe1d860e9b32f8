#pragma once

// Per-pixel math of the sparse stereo stage, shared by the CPU code (the scalar references the
// SIMD kernels are tested against, and the checks) and the CUDA kernels (gpu/). Plain integer
// arithmetic and IEEE float/double operations only, so both give the same bits.

#include <cstdint>

#include "dco/kernels/host_device.hpp"
#include "dco/kernels/stereo_kernels.hpp"

namespace dco::kernels::pixel {

inline constexpr std::int16_t kInvalid = -1;  // dco::stereo::kInvalidDisparity

DCO_HD inline int min_of(int a, int b) {
  return a < b ? a : b;
}
DCO_HD inline int max_of(int a, int b) {
  return a > b ? a : b;
}
DCO_HD inline int clamp_to(int v, int lo, int hi) {
  return v < lo ? lo : (v > hi ? hi : v);
}
DCO_HD inline int abs_of(int v) {
  return v < 0 ? -v : v;
}

DCO_HD inline float infinity() {
#ifdef __CUDA_ARCH__
  return __int_as_float(0x7f800000);
#else
  return __builtin_huge_valf();
#endif
}

DCO_HD inline int popcount64(std::uint64_t v) {
#ifdef __CUDA_ARCH__
  return __popcll(v);
#else
  return __builtin_popcountll(v);
#endif
}

// Mean of a 2x2 block, rounded (the half-size internal image).
DCO_HD inline std::uint8_t half_mean(int a, int b, int c, int d) {
  return static_cast<std::uint8_t>((a + b + c + d + 2) >> 2);
}

// Grey level of a BGR pixel: weights round(w * 2^15) summing to 2^15.
DCO_HD inline std::uint8_t grey_of_bgr(int b, int g, int r) {
  return static_cast<std::uint8_t>((b * 3735 + g * 19235 + r * 9798 + (1 << 14)) >> 15);
}

// Sum of the absolute differences of the four 8-bit channels of two packed pixels.
DCO_HD inline std::uint32_t absdiff_sum(std::uint32_t a, std::uint32_t b) {
  std::uint32_t sum = 0;
  for (int shift = 0; shift < 32; shift += 8) {
    const int ca = static_cast<int>((a >> shift) & 0xff);
    const int cb = static_cast<int>((b >> shift) & 0xff);
    sum += static_cast<std::uint32_t>(ca > cb ? ca - cb : cb - ca);
  }
  return sum;
}

// Largest absolute channel difference of two packed pixels (the arms' colour difference).
DCO_HD inline int colour_diff(std::uint32_t a, std::uint32_t b) {
  int d = 0;
  for (int shift = 0; shift < 32; shift += 8) {
    const int ca = static_cast<int>((a >> shift) & 0xff);
    const int cb = static_cast<int>((b >> shift) & 0xff);
    d = max_of(d, ca > cb ? ca - cb : cb - ca);
  }
  return d;
}

// Length of an arm from `anchor`; at(i) is the packed pixel i steps along it, i = 1 .. limit.
template <class At>
DCO_HD int arm_length(std::uint32_t anchor, const At& at, int limit, const ArmParams& p) {
  std::uint32_t prev = anchor;
  int len = 0;
  for (int i = 1; i <= limit; ++i) {
    const std::uint32_t q = at(i);
    const int to_anchor = colour_diff(q, anchor);
    if (to_anchor >= p.tau1 || colour_diff(q, prev) >= p.tau1) break;
    if (i > p.arm_short && to_anchor >= p.tau2) break;
    len = i;
    prev = q;
  }
  return len;
}

// 3-tap median (the arm smoothing).
DCO_HD inline int median3(int a, int b, int c) {
  return max_of(min_of(a, b), min_of(max_of(a, b), c));
}

// Census descriptor of column x: row(j) points at image row y + j - window_h / 2 (clamped to the
// image). Bits in row-major neighbour order from the most significant used bit down, set where
// the neighbour (columns clamped to the row) is darker than the centre.
template <class Row>
DCO_HD std::uint64_t census_bits(const Row& row, int x, int width, int window_w, int window_h) {
  const int rx = window_w / 2;
  const int ry = window_h / 2;
  const int centre = row(ry)[x];
  std::uint64_t bits = 0;
  for (int j = 0; j < window_h; ++j) {
    const std::uint8_t* r = row(j);
    for (int dx = -rx; dx <= rx; ++dx) {
      if (j == ry && dx == 0) continue;
      bits = (bits << 1) | static_cast<std::uint64_t>(r[clamp_to(x + dx, 0, width - 1)] < centre);
    }
  }
  return bits;
}

// Eq. 1 in fixed point from the two table lookups of the pixel's shortest arm.
DCO_HD inline std::uint32_t matching_cost(std::uint32_t left, std::uint32_t right,
                                          std::uint64_t census_left, std::uint64_t census_right,
                                          int shortest_arm, const CostTableView& t) {
  const std::uint32_t ad = absdiff_sum(left, right);
  const int hd = popcount64(census_left ^ census_right);
  return t.ad[shortest_arm * t.ad_size + static_cast<int>(ad)] +
         t.census[shortest_arm * t.census_size + hd];
}

// round(2^31 / n): the region mean is region_mean(sum, reciprocal(n)).
DCO_HD inline std::uint32_t reciprocal(std::uint32_t n) {
  return ((std::uint32_t{1} << 31) + n / 2) / n;
}
DCO_HD inline std::uint32_t region_mean(std::uint32_t sum, std::uint32_t reciprocal) {
  return static_cast<std::uint32_t>((std::uint64_t{sum} * reciprocal + (std::uint64_t{1} << 30)) >>
                                    31);
}

// One disparity d (increasing by one from 0) of the left image's winner-takes-all state:
// the winner, the best cost at least two disparities from it (uniqueness), the costs at
// winner - 1 and + 1 (subpixel), and what that bookkeeping needs.
struct WtaState {
  std::uint16_t best = kNoCost, second = kNoCost, below = kNoCost, above = kNoCost;
  std::uint16_t prev1 = kNoCost, prev2 = kNoCost, runmin = kNoCost;
  std::int16_t disp = kInvalid;
};
// The state before disparity 0 (WtaState's values), written in place.
template <class U16, class I16>
DCO_HD void wta_start(U16& best, U16& second, U16& below, U16& above, U16& prev1, U16& prev2,
                      U16& runmin, I16& disp) {
  best = second = below = above = prev1 = prev2 = runmin = kNoCost;
  disp = kInvalid;
}
template <class U16, class I16>
DCO_HD void wta_feed(std::uint16_t c, int d, U16& best, U16& second, U16& below, U16& above,
                     U16& prev1, U16& prev2, U16& runmin, I16& disp) {
  if (prev2 < runmin) runmin = prev2;  // best over disparities <= d - 2
  if (c < best) {
    best = c;
    disp = static_cast<std::int16_t>(d);
    second = runmin;
    below = prev1;
    above = kNoCost;
  } else if (d == disp + 1) {
    above = c;
  } else if (c < second) {
    second = c;
  }
  prev2 = prev1;
  prev1 = c;
}
DCO_HD inline void wta_feed(WtaState& s, std::uint16_t c, int d) {
  wta_feed(c, d, s.best, s.second, s.below, s.above, s.prev1, s.prev2, s.runmin, s.disp);
}

// Disparities d .. d + count - 1 (count >= 1) left out of the search: the state that `count`
// wta_feed calls with kNoCost leave (no cost there can win, be second, or serve a subpixel fit).
template <class U16, class I16>
DCO_HD void wta_skip(int d, int count, U16& above, U16& prev1, U16& prev2, U16& runmin,
                     const I16& disp) {
  if (prev2 < runmin) runmin = prev2;
  if (count >= 2 && prev1 < runmin) runmin = prev1;
  if (d == disp + 1) above = kNoCost;
  prev2 = count >= 2 ? kNoCost : prev1;
  prev1 = kNoCost;
}
DCO_HD inline void wta_skip(WtaState& s, int d, int count) {
  wta_skip(d, count, s.above, s.prev1, s.prev2, s.runmin, s.disp);
}

// Left-right check: the right image's winner at x - d agrees with d within max_diff.
DCO_HD inline bool left_right_agree(int x, int d, const std::int16_t* right_row, int max_diff) {
  const int xr = x - d;
  return xr >= 0 && right_row[xr] != kInvalid && abs_of(right_row[xr] - d) <= max_diff;
}

// Uniqueness: kept when best <= keep * second (keep = 1 - ratio) or no second cost exists.
DCO_HD inline bool unique_enough(std::uint16_t best, std::uint16_t second, double keep) {
  return second == kNoCost || !(static_cast<double>(best) > keep * static_cast<double>(second));
}

// A reliable 8-neighbour (at(x, y) is the map before the check) is nearer by more than max_jump:
// the pixel is on the far side of a depth jump.
template <class At>
DCO_HD bool behind_jump(const At& at, int x, int y, int width, int height, int max_jump) {
  const int d = at(x, y);
  for (int ny = max_of(y - 1, 0); ny <= min_of(y + 1, height - 1); ++ny)
    for (int nx = max_of(x - 1, 0); nx <= min_of(x + 1, width - 1); ++nx) {
      const int n = at(nx, ny);
      if (n != kInvalid && n - d > max_jump) return true;
    }
  return false;
}

// The histogram vote's rule (Eq. 4) for one pixel: its new value given the region's reliable
// pixel count, the winning bin's votes and value.
struct VoteParams {
  int min_count = 20;
  double min_ratio = 0.4;
  int tolerance = 1;
  bool fill_invalid = false;
};
DCO_HD inline std::int16_t voted_value(std::int16_t d, std::uint32_t total, std::uint32_t votes,
                                       std::int16_t winner, const VoteParams& p) {
  const bool decided = total >= static_cast<std::uint32_t>(p.min_count) &&
                       static_cast<double>(votes) >= p.min_ratio * static_cast<double>(total);
  if (!decided) return d;
  if (d == kInvalid && !p.fill_invalid) return d;
  if (d != kInvalid && abs_of(winner - d) <= p.tolerance) return d;
  return winner;
}

// Equiangular fit through the costs at d-1, d, d+1 (a V with equal slopes, the shape of
// absolute-difference and census costs near their minimum; a parabola pulls estimates towards
// whole pixels on them): the offset of its tip, in [-0.5, 0.5]; 0 when a neighbour is missing or
// d is not a strict minimum of the three.
DCO_HD inline float subpixel_offset(std::uint16_t below, std::uint16_t best, std::uint16_t above) {
  if (below == kNoCost || above == kNoCost || below < best || above < best) return 0.0f;
  const int rise = (below > above ? int(below) : int(above)) - int(best);
  if (rise <= 0) return 0.0f;
  // |below - above| <= rise, since both are at least best.
  return float(int(below) - int(above)) / (2.0f * float(rise));
}

// The winner-takes-all disparity with its subpixel fit, in [0, max_value].
DCO_HD inline float raw_disparity(std::int16_t d, std::uint16_t below, std::uint16_t best,
                                  std::uint16_t above, bool subpixel, float max_value) {
  const float v = static_cast<float>(d) + (subpixel ? subpixel_offset(below, best, above) : 0.0f);
  return v < 0.0f ? 0.0f : (v > max_value ? max_value : v);
}

// A checked disparity with its subpixel fit (none where a vote changed the value), at most
// max_value; +inf where the checks left no value or the value is not positive (no finite depth).
DCO_HD inline float sparse_disparity(std::int16_t d, bool voted, std::uint16_t below,
                                     std::uint16_t best, std::uint16_t above, bool subpixel,
                                     float max_value) {
  const float unknown = infinity();
  if (d == kInvalid) return unknown;
  const float offset = subpixel && !voted ? subpixel_offset(below, best, above) : 0.0f;
  float v = static_cast<float>(d) + offset;
  if (v > max_value) v = max_value;
  return v > 0.0f ? v : unknown;
}

}  // namespace dco::kernels::pixel
