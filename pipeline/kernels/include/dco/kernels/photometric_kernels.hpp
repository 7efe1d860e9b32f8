#pragma once

// Row kernels of the densifier's photometric refinement (dco/pipeline/densify/
// photometric_refiner.hpp). Dispatched at run time like the other kernels; dco::kernels::scalar
// holds the references, whose per-pixel math is kernels::pixel's (photometric_pixel.hpp). The
// vector versions do the same float operations in the same order, no fused multiply-add, so all
// of them give the same bits.

#include <cmath>
#include <cstdint>

#include "dco/kernels/host_device.hpp"
#include "dco/kernels/photometric_pixel.hpp"

namespace dco::kernels {

// The grey level and derivatives of one image row: out.v[x] ... out.yy[x] =
// pixel::derivatives_at(rows, ...) with the columns x - 2 .. x + 2 clamped to the row, from rows
// y - 2 .. y + 2 (clamped by the caller).
struct DerivativeRows {
  float* v;
  float* x;
  float* y;
  float* xx;
  float* xy;
  float* yy;
};
void derivative_row(const std::uint8_t* const rows[5], int width, const DerivativeRows& out);

// One row's linearised data terms and smoothness weights:
//   a[x], rhs[x] = pixel::photometric_data_term(left at x, right at x - d[x], d[x]), the right
//     image's derivatives interpolated linearly between the columns floor(x - d[x]) and the one
//     after, each clamped to the row;
//   smooth[x] = pixel::photometric_smoothness of d's row neighbours (clamped) and of d_up[x],
//     d_down[x] (the caller's rows above and below, the row itself at the image's edges).
struct PhotometricTermRows {
  const float* left[6];   // the left image's DerivativeRows at this row: v, x, y, xx, xy, yy
  const float* right[6];  // the right image's
  const float* d;
  const float* d_up;
  const float* d_down;
  int width;
};
void photometric_terms_row(const PhotometricTermRows& in, const pixel::PhotometricWeights& w,
                           float* a, float* rhs, float* smooth);

// The couplings of one row from the smoothness weights of it (s) and of the row below (s_down,
// null for the last row): wx[x] = pixel::photometric_edge(s[x], s[x + 1]) (0 for the last column),
// wy[x] = pixel::photometric_edge(s[x], s_down[x]) (0 for the last row), and
// inverse_diagonal[x] = pixel::photometric_inverse_diagonal(a[x], wx[x - 1], wx[x], wy_up[x],
// wy[x]) with the row above's wy (wy_up, null for the first row; 0 outside the image).
struct CouplingRow {
  const float* a;
  const float* s;
  const float* s_down;
  const float* wy_up;
  int width;
};
void photometric_couplings_row(const CouplingRow& row, float* wx, float* wy,
                               float* inverse_diagonal);

// One colour of a red-black SOR sweep on one row: d[x] = pixel::sor_step(...) for every x with
// x % 2 == first, from the couplings of photometric_couplings_row (wy_up the row above's, null
// for the first row, with d_up; wy 0 and d_down null for the last row). The other colour, which
// the step reads, is left as it is. `scratch` holds `width` floats.
struct SorRow {
  const float* rhs;
  const float* inverse_diagonal;
  const float* wx;
  const float* wy;
  const float* wy_up;
  const float* d_up;
  const float* d_down;
  int width;
};
void sor_row(const SorRow& row, int first, float omega, float* d, float* scratch);

// One pixel of each row kernel above: the scalar references and the vector kernels' borders loop
// over these, the GPU passes (dco/gpu/photometric_passes.hpp) call them once per grid point.
DCO_HD inline void derivative_at(const std::uint8_t* const rows[5], int width, int x,
                                 const DerivativeRows& out) {
  const auto c = [width](int column) { return pixel::clamp_to(column, 0, width - 1); };
  const pixel::Derivatives d =
      pixel::derivatives_at(rows, c(x - 2), c(x - 1), x, c(x + 1), c(x + 2));
  out.v[x] = d.v, out.x[x] = d.x, out.y[x] = d.y;
  out.xx[x] = d.xx, out.xy[x] = d.xy, out.yy[x] = d.yy;
}

DCO_HD inline void photometric_terms_at(const PhotometricTermRows& in,
                                        const pixel::PhotometricWeights& w, int x, float* a,
                                        float* rhs, float* smooth) {
  const int last = in.width - 1;
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

// The couplings in two steps: wx[x] and wy[x], then the inverse diagonal, which reads the row's
// wx[x] and wy[x] and the row above's wy (a pass over an image must finish the first step on
// every row before the second).
DCO_HD inline void photometric_edges_at(const CouplingRow& row, int x, float* wx, float* wy) {
  wx[x] = x < row.width - 1 ? pixel::photometric_edge(row.s[x], row.s[x + 1]) : 0.0f;
  wy[x] = row.s_down ? pixel::photometric_edge(row.s[x], row.s_down[x]) : 0.0f;
}
DCO_HD inline void photometric_inverse_diagonal_at(const CouplingRow& row, int x, const float* wx,
                                                   const float* wy, float* inverse_diagonal) {
  const float w_left = x > 0 ? pixel::photometric_edge(row.s[x - 1], row.s[x]) : 0.0f;
  inverse_diagonal[x] = pixel::photometric_inverse_diagonal(row.a[x], w_left, wx[x],
                                                            row.wy_up ? row.wy_up[x] : 0.0f, wy[x]);
}

DCO_HD inline void sor_at(const SorRow& row, int x, float omega, float* d) {
  const int last = row.width - 1;
  const float w_left = x > 0 ? row.wx[x - 1] : 0.0f;
  const float d_left = x > 0 ? d[x - 1] : 0.0f;
  const float d_right = x < last ? d[x + 1] : 0.0f;
  const float w_up = row.wy_up ? row.wy_up[x] : 0.0f;
  const float d_up = row.d_up ? row.d_up[x] : 0.0f;
  const float d_down = row.d_down ? row.d_down[x] : 0.0f;
  d[x] = pixel::sor_step(d[x], row.rhs[x], row.inverse_diagonal[x], w_left, d_left, row.wx[x],
                         d_right, w_up, d_up, row.wy[x], d_down, omega);
}

namespace scalar {
void derivative_row(const std::uint8_t* const rows[5], int width, const DerivativeRows& out);
void photometric_terms_row(const PhotometricTermRows& in, const pixel::PhotometricWeights& w,
                           float* a, float* rhs, float* smooth);
void photometric_couplings_row(const CouplingRow& row, float* wx, float* wy,
                               float* inverse_diagonal);
void sor_row(const SorRow& row, int first, float omega, float* d);
}  // namespace scalar

}  // namespace dco::kernels
