#pragma once

// The photometric refinement's scalar row kernels over a range of columns: the whole row for
// dco::kernels::scalar, the borders and the tails for the SIMD versions. The order of the float
// operations (kernels::pixel's) is the contract the vector code follows.

#include <cmath>

#include "dco/kernels/photometric_kernels.hpp"

namespace dco::kernels::detail {

inline void derivative_range(const std::uint8_t* const rows[5], int width, int begin, int end,
                             const DerivativeRows& out) {
  for (int x = begin; x < end; ++x) {
    const auto c = [width](int column) { return pixel::clamp_to(column, 0, width - 1); };
    const pixel::Derivatives d =
        pixel::derivatives_at(rows, c(x - 2), c(x - 1), x, c(x + 1), c(x + 2));
    out.v[x] = d.v, out.x[x] = d.x, out.y[x] = d.y;
    out.xx[x] = d.xx, out.xy[x] = d.xy, out.yy[x] = d.yy;
  }
}

inline void photometric_terms_range(const PhotometricTermRows& in,
                                    const pixel::PhotometricWeights& w, int begin, int end,
                                    float* a, float* rhs, float* smooth) {
  const int last = in.width - 1;
  for (int x = begin; x < end; ++x) {
    const float d = in.d[x];
    const float xs = static_cast<float>(x) - d;
    const float floor = std::floor(xs);
    const float t = xs - floor;
    const int j = static_cast<int>(floor);
    const int j0 = pixel::clamp_to(j, 0, last), j1 = pixel::clamp_to(j + 1, 0, last);
    const auto sample = [&](int k) {
      return pixel::lerp_sample(in.right[k][j0], in.right[k][j1], t);
    };
    const pixel::Derivatives r{sample(0), sample(1), sample(2), sample(3), sample(4), sample(5)};
    const pixel::Derivatives l{in.left[0][x], in.left[1][x], in.left[2][x],
                               in.left[3][x], in.left[4][x], in.left[5][x]};
    pixel::photometric_data_term(l, r, d, w, a[x], rhs[x]);
    smooth[x] = pixel::photometric_smoothness(in.d[pixel::clamp_to(x - 1, 0, last)],
                                              in.d[pixel::clamp_to(x + 1, 0, last)], in.d_up[x],
                                              in.d_down[x], w.alpha);
  }
}

inline void photometric_couplings_range(const CouplingRow& row, int begin, int end, float* wx,
                                        float* wy, float* inverse_diagonal) {
  const int last = row.width - 1;
  // wx of x - 1 first: the inverse diagonal reads it.
  for (int x = begin; x < end; ++x) {
    wx[x] = x < last ? pixel::photometric_edge(row.s[x], row.s[x + 1]) : 0.0f;
    wy[x] = row.s_down ? pixel::photometric_edge(row.s[x], row.s_down[x]) : 0.0f;
  }
  for (int x = begin; x < end; ++x) {
    const float w_left = x > 0 ? pixel::photometric_edge(row.s[x - 1], row.s[x]) : 0.0f;
    inverse_diagonal[x] = pixel::photometric_inverse_diagonal(
        row.a[x], w_left, wx[x], row.wy_up ? row.wy_up[x] : 0.0f, wy[x]);
  }
}

// Columns begin, begin + 2, ... below end: the caller starts at a pixel of the colour to update.
inline void sor_range(const SorRow& row, int begin, int end, float omega, float* d) {
  const int last = row.width - 1;
  for (int x = begin; x < end; x += 2) {
    const float w_left = x > 0 ? row.wx[x - 1] : 0.0f;
    const float d_left = x > 0 ? d[x - 1] : 0.0f;
    const float d_right = x < last ? d[x + 1] : 0.0f;
    const float w_up = row.wy_up ? row.wy_up[x] : 0.0f;
    const float d_up = row.d_up ? row.d_up[x] : 0.0f;
    const float d_down = row.d_down ? row.d_down[x] : 0.0f;
    d[x] = pixel::sor_step(d[x], row.rhs[x], row.inverse_diagonal[x], w_left, d_left, row.wx[x],
                           d_right, w_up, d_up, row.wy[x], d_down, omega);
  }
}

}  // namespace dco::kernels::detail
