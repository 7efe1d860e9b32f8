#pragma once

// Per-pixel math of the densify solver (dco::densify::GridSystem), shared by the scalar row
// kernels (the references the SIMD kernels match) and the GPU passes: the same float operations
// in the same order, no fused multiply-add, so all of them give the same bits.

#include <algorithm>
#include <cmath>
#include <limits>

#include "dco/kernels/densify_kernels.hpp"
#include "dco/kernels/host_device.hpp"

namespace dco::kernels::pixel {

// Σ of the vertical neighbour terms of column c (0 on a row without neighbours), for a GridRow
// or a SplitSmoothRow (the same members).
template <class Row>
DCO_HD inline float vertical_term(const Row& r, int c) {
  float v = 0.0f;
  if (r.x_below != nullptr) v = r.wy[c] * r.x_below[c];
  if (r.x_above != nullptr) v = v + r.wy_above[c] * r.x_above[c];
  return v;
}

// The Gauss-Seidel value of x[c]: (b + Σ w x(neighbour)) / diag.
DCO_HD inline float smooth_at(const GridRow& r, const float* b, const float* x, int c) {
  float v = b[c];
  if (c + 1 < r.width) v = v + r.wx[c] * x[c + 1];
  if (c > 0) v = v + r.wx[c - 1] * x[c - 1];
  return (v + vertical_term(r, c)) * r.inv_diag[c];
}

// smooth_at for pixel i of a row in the split layout (SplitSmoothRow): column 2 i + parity.
DCO_HD inline float smooth_split_at(const SplitSmoothRow& r, int i) {
  const int c = 2 * i + r.parity;
  const int right = i + r.parity;  // the neighbours' index among the other parity's pixels
  float v = r.b[i];
  if (c + 1 < r.width) v = v + r.wx[i] * r.x_other[right];
  if (c > 0) v = v + r.wx_other[right - 1] * r.x_other[right - 1];
  return (v + vertical_term(r, i)) * r.inv_diag[i];
}

// (b - A x) at pixel i of a row in the split layout: apply_at's operations, then b minus them.
DCO_HD inline float residual_split_at(const SplitResidualRow& r, int i) {
  const SplitSmoothRow& s = r.row;
  const int c = 2 * i + s.parity;
  const int right = i + s.parity;
  float v = r.diag[i] * r.x[i];
  if (c + 1 < s.width) v = v - s.wx[i] * s.x_other[right];
  if (c > 0) v = v - s.wx_other[right - 1] * s.x_other[right - 1];
  return s.b[i] - (v - vertical_term(s, i));
}

// (A x)[c].
DCO_HD inline float apply_at(const GridRow& r, const float* x, int c) {
  float v = r.diag[c] * x[c];
  if (c + 1 < r.width) v = v - r.wx[c] * x[c + 1];
  if (c > 0) v = v - r.wx[c - 1] * x[c - 1];
  return v - vertical_term(r, c);
}

// Weight of one smoothness edge (edge_weights_row); `colour` is 1 without image guidance.
DCO_HD inline float edge_weight(bool barrier_between, float strength_a, float strength_b,
                                float colour, float scale, float floor) {
  if (barrier_between) return scale * floor;
  // The lesser strength, and NaN from either end (a NaN at b alone would lose in the compare):
  // a strength that is not finite must reach every solve path's residual, the half-size one's
  // too, which folds the edges inside a 2x2 block away.
  const float low = strength_b < strength_a || strength_b != strength_b ? strength_b : strength_a;
  const float weight = (1.0f - low) * colour;
  return scale * (weight < floor ? floor : weight);
}

inline constexpr int kDotLanes = 16;

// Σ a[i] b[i] of one row as dot_row defines it: sixteen float partial sums (lane i % 16), the
// last n % 16 products in double, then the partial sums, all added up in double.
DCO_HD inline double dot_row(const float* a, const float* b, int n) {
  float partial[kDotLanes] = {};
  int i = 0;
  for (; i + kDotLanes <= n; i += kDotLanes)
    for (int lane = 0; lane < kDotLanes; ++lane) partial[lane] += a[i + lane] * b[i + lane];
  double sum = 0;
  for (; i < n; ++i) sum += static_cast<double>(a[i]) * b[i];
  for (int lane = 0; lane < kDotLanes; ++lane) sum += partial[lane];
  return sum;
}

// A sparse or previous value that exists: finite and positive (two comparisons, NaN fails both,
// so loops over it vectorise). Host code: the densifier builds its system on the CPU.
inline bool known_value(float v) {
  return v > 0.0f && v < std::numeric_limits<float>::infinity();
}

// The least disparity jump across a hole run that the occlusion rule reads as a jump, px.
inline constexpr float kMinOcclusionJump = 2.0f;

// The occlusion strip of a hole run `width` pixels wide between the known values `far` (on its
// left) and `near` (on its right) (occlusion_fill_row): with a jump of at least
// kMinOcclusionJump and a width from jump - a to jump + 4 a, a = max(2 px, jump / 4), its first
// min(width, jump rounded) pixels; else none (0). Pixels past the strip are the near surface's
// unmatched rim.
inline int occlusion_strip(float far, float near, int width) {
  constexpr float kWidthSlack = 2.0f;
  constexpr float kWidthShare = 0.25f;
  constexpr float kRimAllowances = 4.0f;
  const float jump = near - far;
  const float allowance = std::fmax(kWidthSlack, kWidthShare * jump);
  const auto w = static_cast<float>(width);
  if (!(jump >= kMinOcclusionJump) || w < jump - allowance || w > jump + kRimAllowances * allowance)
    return 0;
  return std::min(width, static_cast<int>(std::lround(jump)));
}

// The rim pixels of a run with a strip that keep the hole hint: the strip's edge is known only
// to a pixel or two (the jump comes from two noisy matches).
inline constexpr int kRimHintPixels = 2;

// Takes back from the holes of [from, end) the hole hint that data_terms_row gave them (weight
// hint_weight towards hint[x] where hint[x] > 0); matches are left alone.
inline void drop_hole_hints(const float* sparse, const float* hint, int from, int end,
                            float hint_weight, float* data, float* b) {
  for (int x = from; x < end; ++x) {
    if (known_value(sparse[x]) || !(hint[x] > 0.0f)) continue;
    data[x] -= hint_weight;
    b[x] -= hint_weight * hint[x];
  }
}

// Applies the occlusion rule to the hole run [start, end) of a row (occlusion_fill_row) and
// returns the pixels of its strip (none when rule.weight is 0).
// - The strip is pulled to the value left of it (data[x] += rule.weight, b[x] += rule.weight *
//   far). The rim past it belongs to the near surface: beyond its first kRimHintPixels, its holes
//   drop the hole hint (the weak pull towards the farther row neighbour), so the smoothness with
//   the near surface decides them.
// - A run without a strip whose left neighbour is the nearer one by kMinOcclusionJump or more
//   lies right of a near surface, where the left image holds no occlusion: its holes are
//   matching failures of either surface, and drop the hint too.
// - The previous run of the row, [prev_start, prev_end), is one with a known left neighbour that
//   held no strip (prev_start <= 0: none); both become this run's for the next call (prev_start
//   -1 when it held a strip or dropped its hints, so it is not merged again). When the run alone
//   holds no strip and at most kMaxSpeck matches lie between it and the previous run, the span from
//   the previous run's start is tried: a match inside a strip cannot be right, since the right
//   camera does not see the strip, and a stray one would otherwise split the strip into runs too
//   narrow.
// Shared by the scalar and SIMD row walks, so both weight the same pixels in the same order.
inline int fill_occlusion_run(const float* sparse, const float* hint, int start, int end,
                              const OcclusionRule& rule, float* data, float* b, int& prev_start,
                              int& prev_end) {
  constexpr int kMaxSpeck = 4;
  int from = start;
  int count = 0;
  if (rule.weight > 0.0f) {
    count = occlusion_strip(sparse[start - 1], sparse[end], end - start);
    if (count == 0 && prev_start > 0 && start - prev_end <= kMaxSpeck) {
      from = prev_start;
      count = occlusion_strip(sparse[prev_start - 1], sparse[end], end - prev_start);
    }
  }
  const float far = sparse[from - 1];
  for (int x = from; x < from + count; ++x) {
    data[x] += rule.weight;
    b[x] += rule.weight * far;
  }
  const bool right_of_near = count == 0 && sparse[start - 1] - sparse[end] >= kMinOcclusionJump;
  if (count > 0)
    drop_hole_hints(sparse, hint, from + count + kRimHintPixels, end, rule.hint_weight, data, b);
  else if (right_of_near)
    drop_hole_hints(sparse, hint, start, end, rule.hint_weight, data, b);
  prev_start = count > 0 || right_of_near ? -1 : start;
  prev_end = end;
  return count;
}

// The hint of a pixel from its left value (negative when the path to it crosses a weak edge;
// -0 for "none, crossed") and its right value and flag (hole_hint_row): the farther of the two
// unless exactly one path crosses a weak edge; the one that exists when the other does not.
inline float hole_hint(float signed_left, float right, bool right_crossed) {
  const bool left_crossed = std::signbit(signed_left);
  const float left = std::fabs(signed_left);
  const float both = left_crossed == right_crossed ? (right < left ? right : left)
                     : left_crossed                ? right
                                                   : left;
  return left <= 0.0f ? right : right > 0.0f ? both : left;
}

// diag = data + the weights of the edges that exist (GridSystem::update_diagonal).
DCO_HD inline float diagonal(float data, const float* wx, const float* wy, const float* wy_above,
                             int x, int width, bool has_below) {
  float s = data;
  if (x + 1 < width) s += wx[x];
  if (x > 0) s += wx[x - 1];
  if (has_below) s += wy[x];
  if (wy_above != nullptr) s += wy_above[x];
  return s;
}
DCO_HD inline float inverse_diagonal(float diag) {
  return diag > 0 ? 1.0f / diag : 0.0f;
}

// One window offset k of match_plane_row_sums at one pixel: sums[j * stride] += f_j(k) in_j.
inline void match_plane_row_step(float match, float d, float dd, float k, float k2, float* sums,
                                 int stride) {
  sums[0] += 1.0f * match;
  sums[stride] += k * match;
  sums[2 * stride] += k2 * match;
  sums[3 * stride] += 1.0f * d;
  sums[4 * stride] += k * d;
  sums[5 * stride] += 1.0f * dd;
}

// One window row at offset v of match_plane_window_add at one pixel (row sums r, window sums s,
// `stride` floats between arrays).
// Its last four sums (Σd, Σud, Σvd, Σd²), the ones with disparities.
inline void match_plane_window_disparity_step(const float* r, float v, int stride, float* s) {
  const float rd = r[3 * stride], rud = r[4 * stride], rdd = r[5 * stride];
  s[6 * stride] += 1.0f * rd;
  s[7 * stride] += 1.0f * rud;
  s[8 * stride] += v * rd;
  s[9 * stride] += 1.0f * rdd;
}
inline void match_plane_window_step(const float* r, float v, float v2, int stride, float* s) {
  const float r0 = r[0], r1 = r[stride], r2 = r[2 * stride];
  s[0] += 1.0f * r0;
  s[stride] += 1.0f * r1;
  s[2 * stride] += v * r0;
  s[3 * stride] += 1.0f * r2;
  s[4 * stride] += v * r1;
  s[5 * stride] += v2 * r0;
  match_plane_window_disparity_step(r, v, stride, s);
}

// match_plane_window_slide at one pixel (window sums s of the window centred one row up, the
// row sums `left` of the row that left it and `entered` of the row that entered it, each
// nullptr for none, radius r; `stride` floats between arrays): the six whole-number sums moved
// one row down. With e/l the entering/leaving row's Σ1 (and likewise for Σu, Σu²), a sum over
// the rows at offset v from the centre, Σ v^p x, becomes Σ (v - 1)^p x over the new window:
// every step is exact on whole numbers.
inline void match_plane_window_move(const float* left, const float* entered, float r, int stride,
                                    float* s) {
  const float l0 = left != nullptr ? left[0] : 0.0f, l1 = left != nullptr ? left[stride] : 0.0f;
  const float l2 = left != nullptr ? left[2 * stride] : 0.0f;
  const float e0 = entered != nullptr ? entered[0] : 0.0f;
  const float e1 = entered != nullptr ? entered[stride] : 0.0f;
  const float e2 = entered != nullptr ? entered[2 * stride] : 0.0f;
  const float r1 = r + 1.0f;
  const float count = s[0] - l0 + e0;
  const float su = s[stride] - l1 + e1;
  // Σ (v' + 1) x and Σ (v' + 1)^2 x over the new window (v' its offsets), from the old sums.
  const float sv_up = s[2 * stride] + r * l0 + r1 * e0;
  const float svv_up = s[5 * stride] - r * r * l0 + r1 * r1 * e0;
  const float suv_up = s[4 * stride] + r * l1 + r1 * e1;
  s[0] = count;
  s[stride] = su;
  s[2 * stride] = sv_up - count;
  s[3 * stride] = s[3 * stride] - l2 + e2;
  s[4 * stride] = suv_up - su;
  s[5 * stride] = svv_up - 2.0f * sv_up + count;
}

// The least-squares plane d = md + a (u - mu) + b (v - mv) through a window's matches, from its
// sums (see match_plane_row), centred about the matches' mean position and value. Its value at
// the window's centre (u = v = 0) when the pixel is a match, the window holds rule.min_count
// matches not all on one line, and their residual sum of squares cdd - a cud - b cvd is at most
// rule.max_square per match (compared without dividing by the determinant); else NaN. Every
// operation is a float product, sum or quotient in this order (the vector kernels repeat it).
inline float match_plane(float count, float su, float sv, float suu, float suv, float svv, float sd,
                         float sud, float svd, float sdd, float own, const MatchPlaneRule& rule) {
  const float inv = 1.0f / (count > 1.0f ? count : 1.0f);
  const float mu = su * inv, mv = sv * inv, md = sd * inv;
  const float cuu = suu - count * mu * mu;
  const float cuv = suv - count * mu * mv;
  const float cvv = svv - count * mv * mv;
  const float cud = sud - count * mu * md;
  const float cvd = svd - count * mv * md;
  const float cdd = sdd - count * md * md;
  const float det = cuu * cvv - cuv * cuv;
  const float a_det = cvv * cud - cuv * cvd;
  const float b_det = cuu * cvd - cuv * cud;
  const bool fits = known_value(own) && count >= rule.min_count && det > 1e-3f * count * count &&
                    (cdd - rule.max_square * count) * det <= a_det * cud + b_det * cvd;
  return fits ? rule.offset + (md - (a_det * mu + b_det * mv) / det)
              : std::numeric_limits<float>::quiet_NaN();
}

// A pixel of the input row after the match planes (match_plane_select_half_row): the plane's value
// where the pixel holds its grid pixel's own value and a plane was kept, else its own.
inline float match_plane_select(float sparse, float own, float plane) {
  return (sparse == own) & (plane == plane) ? plane : sparse;
}

}  // namespace dco::kernels::pixel
