#pragma once

// The scalar densify kernels over a range of columns: the whole row for dco::kernels::scalar,
// the borders and the last partial vector for the SIMD versions. The order of the float
// operations here is the contract the vector code follows.

#include "dco/kernels/densify_kernels.hpp"

namespace dco::kernels::detail {

// Σ of the vertical neighbour terms of column c (0 on a row without neighbours).
inline float vertical_term(const GridRow& r, int c) {
  float v = 0.0f;
  if (r.x_below != nullptr) v = r.wy[c] * r.x_below[c];
  if (r.x_above != nullptr) v = v + r.wy_above[c] * r.x_above[c];
  return v;
}

inline void smooth_range(const GridRow& r, int start, const float* b, float* x, int begin,
                         int end) {
  int c = begin + ((begin - start) & 1);  // first column of the colour
  for (; c < end; c += 2) {
    float v = b[c];
    if (c + 1 < r.width) v = v + r.wx[c] * x[c + 1];
    if (c > 0) v = v + r.wx[c - 1] * x[c - 1];
    x[c] = (v + vertical_term(r, c)) * r.inv_diag[c];
  }
}

inline void apply_range(const GridRow& r, const float* x, float* out, int begin, int end) {
  for (int c = begin; c < end; ++c) {
    float v = r.diag[c] * x[c];
    if (c + 1 < r.width) v = v - r.wx[c] * x[c + 1];
    if (c > 0) v = v - r.wx[c - 1] * x[c - 1];
    out[c] = v - vertical_term(r, c);
  }
}

inline constexpr int kDotLanes = 16;

// Adds the products of [begin, n) in double and then the partial sums, lane by lane.
inline double finish_dot(const float* a, const float* b, int begin, int n,
                         const float (&partial)[kDotLanes]) {
  double sum = 0;
  for (int i = begin; i < n; ++i) sum += static_cast<double>(a[i]) * b[i];
  for (const float p : partial) sum += p;
  return sum;
}

}  // namespace dco::kernels::detail
