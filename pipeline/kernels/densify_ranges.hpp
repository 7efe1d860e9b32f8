#pragma once

// The scalar densify kernels over a range of columns: the whole row for dco::kernels::scalar,
// the borders and the last partial vector for the SIMD versions. The order of the float
// operations here is the contract the vector code follows.

#include <algorithm>

#include "dco/kernels/densify_kernels.hpp"
#include "dco/kernels/densify_pixel.hpp"

namespace dco::kernels::detail {

inline void smooth_range(const GridRow& r, int start, const float* b, float* x, int begin,
                         int end) {
  int c = begin + ((begin - start) & 1);  // first column of the colour
  for (; c < end; c += 2) x[c] = pixel::smooth_at(r, b, x, c);
}

inline void smooth_split_range(const SplitSmoothRow& r, float* x, int begin, int end) {
  for (int i = begin; i < end; ++i) x[i] = pixel::smooth_split_at(r, i);
}

inline void residual_split_range(const SplitResidualRow& r, float* out, int begin, int end) {
  for (int i = begin; i < end; ++i) out[i] = pixel::residual_split_at(r, i);
}

// match_plane_window_slide over columns [begin, end): the whole-number sums moved, the
// disparity sums added up afresh.
inline void match_plane_window_slide_range(const float* const* rows, const float* left, int radius,
                                           int n, int begin, int end, float* sums) {
  const float* entered = rows[2 * radius];
  const auto r = static_cast<float>(radius);
  for (int x = begin; x < end; ++x)
    pixel::match_plane_window_move(left != nullptr ? left + x : nullptr,
                                   entered != nullptr ? entered + x : nullptr, r, n, sums + x);
  for (int k = 6; k < 10; ++k)
    std::fill(sums + k * static_cast<std::ptrdiff_t>(n) + begin,
              sums + k * static_cast<std::ptrdiff_t>(n) + end, 0.0f);
  for (int j = -radius; j <= radius; ++j) {
    const float* row = rows[j + radius];
    if (row == nullptr) continue;
    const auto v = static_cast<float>(j);
    for (int x = begin; x < end; ++x)
      pixel::match_plane_window_disparity_step(row + x, v, n, sums + x);
  }
}

inline void inverse_diagonal_range(const float* diag, int begin, int end, float* inv) {
  for (int i = begin; i < end; ++i) inv[i] = pixel::inverse_diagonal(diag[i]);
}

inline void split_range(const float* in, int width, int begin, int end, float* even, float* odd) {
  for (int i = begin; i < end; ++i) {
    even[i] = in[2 * i];
    if (2 * i + 1 < width) odd[i] = in[2 * i + 1];
  }
}

inline void merge_range(const float* even, const float* odd, int width, int begin, int end,
                        float* out) {
  for (int i = begin; i < end; ++i) {
    out[2 * i] = even[i];
    if (2 * i + 1 < width) out[2 * i + 1] = odd[i];
  }
}

inline void apply_range(const GridRow& r, const float* x, float* out, int begin, int end) {
  for (int c = begin; c < end; ++c) out[c] = pixel::apply_at(r, x, c);
}

inline void edge_range(const EdgeEnds& e, const EdgeRule& rule, int begin, int end, float* out) {
  for (int i = begin; i < end; ++i) {
    float colour = 1.0f;
    if (rule.colour != nullptr)
      colour = rule.colour[e.grey_a[i] > e.grey_b[i] ? e.grey_a[i] - e.grey_b[i]
                                                     : e.grey_b[i] - e.grey_a[i]];
    out[i] = pixel::edge_weight(e.barrier_a[i] != e.barrier_b[i], e.strength_a[i], e.strength_b[i],
                                colour, rule.scale, rule.floor);
  }
}

inline void data_terms_range(const float* sparse, const float* hint, const float* previous,
                             const DataTermRule& rule, int begin, int end, float* data, float* b,
                             float* low, float* high) {
  for (int x = begin; x < end; ++x) {
    const bool k = pixel::known_value(sparse[x]);
    const float w = k ? rule.lambda_d : hint[x] > 0.0f ? rule.hint_weight : 0.0f;
    const float v = k ? sparse[x] : hint[x] > 0.0f ? hint[x] : 0.0f;
    float a = rule.regulariser + w;
    float r = 0.0f + w * v;
    if (k) *low = std::min(*low, sparse[x]), *high = std::max(*high, sparse[x]);
    if (previous != nullptr) {
      const bool kp = pixel::known_value(previous[x]);
      a = a + (kp ? rule.lambda_s2 : 0.0f);
      r = r + (kp ? rule.lambda_s2 : 0.0f) * (kp ? previous[x] : 0.0f);
      if (kp) *low = std::min(*low, previous[x]), *high = std::max(*high, previous[x]);
    }
    data[x] = a;
    b[x] = r;
  }
}

inline void diagonal_range(const float* data, const float* wx, const float* wy,
                           const float* wy_above, int width, int begin, int end, float* diag,
                           float* inv_diag) {
  for (int x = begin; x < end; ++x) {
    diag[x] = pixel::diagonal(data[x], wx, wy, wy_above, x, width, wy != nullptr);
    inv_diag[x] = pixel::inverse_diagonal(diag[x]);
  }
}

inline constexpr int kDotLanes = pixel::kDotLanes;

// Adds the products of [begin, n) in double and then the partial sums, lane by lane.
inline double finish_dot(const float* a, const float* b, int begin, int n,
                         const float (&partial)[kDotLanes]) {
  double sum = 0;
  for (int i = begin; i < n; ++i) sum += static_cast<double>(a[i]) * b[i];
  for (const float p : partial) sum += p;
  return sum;
}

}  // namespace dco::kernels::detail
